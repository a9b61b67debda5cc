//! Embeds the git commit sonarnet is built from (`SONARNET_GIT_COMMIT`,
//! recorded in `run.json`), when it is built from a git checkout.
//!
//! Cargo treats a `rerun-if-changed` path that does not exist as changed on
//! every build, so only files that exist are watched: a checkout without
//! `.git/packed-refs` (a fresh `git init`, many CI clones) would otherwise
//! rebuild the crate on every `cargo run`.

use std::path::Path;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git").args(args).output().ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
            .filter(|s| !s.is_empty())
    };
    // Rebuild when HEAD moves: HEAD itself, the branch it names (a loose ref
    // or a line of packed-refs; a ref that is packed or unpacked deletes or
    // creates the loose file, which is a change of a watched file too).
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        let common = git(&["rev-parse", "--git-common-dir"]).unwrap_or_else(|| dir.clone());
        let mut watched = vec![format!("{dir}/HEAD"), format!("{common}/packed-refs")];
        if let Some(r) = git(&["symbolic-ref", "-q", "HEAD"]) {
            let loose = format!("{common}/{r}");
            // An unborn branch has no ref yet: its first commit creates one
            // in refs/heads, which cargo then sees as a changed directory.
            if Path::new(&loose).is_file() {
                watched.push(loose);
            } else {
                watched.push(format!("{common}/refs/heads"));
            }
        }
        for path in watched.iter().filter(|p| Path::new(p).exists()) {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    if let Some(sha) = git(&["rev-parse", "HEAD"]) {
        println!("cargo:rustc-env=SONARNET_GIT_COMMIT={sha}");
    }
}
