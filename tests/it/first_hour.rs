//! What a newcomer meets first: builds that stay built, refusals instead of
//! silent truncation, and errors that say what to write.

use crate::util::TempDir;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The newest compiled build script of this package, next to the test
/// binary (`target/PROFILE/build/sonarnet-HASH/build-script-build`).
fn build_script() -> PathBuf {
    let exe = std::env::current_exe().expect("test binary path");
    let build = exe
        .parent()
        .and_then(Path::parent)
        .expect("target/PROFILE")
        .join("build");
    let mut found: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(&build)
        .expect("target/PROFILE/build")
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().starts_with("sonarnet-"))
        .map(|e| e.path().join("build-script-build"))
        .filter(|p| p.is_file())
        .filter_map(|p| Some((p.metadata().ok()?.modified().ok()?, p)))
        .collect();
    found.sort();
    found.pop().expect("a compiled build script of sonarnet").1
}

fn git(dir: &Path, args: &[&str]) {
    let out = Command::new("git")
        .args([
            "-c",
            "user.name=t",
            "-c",
            "user.email=t@t",
            "-c",
            "init.defaultBranch=main",
        ])
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run git");
    assert!(
        out.status.success(),
        "git {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The `rerun-if-changed` paths the build script prints when run in `dir`.
fn watched(dir: &Path) -> Vec<PathBuf> {
    let out_dir = TempDir::new("build-out");
    let out = Command::new(build_script())
        .current_dir(dir)
        .env("OUT_DIR", out_dir.path())
        .output()
        .expect("run the build script");
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.strip_prefix("cargo:rerun-if-changed="))
        .map(|p| dir.join(p))
        .collect()
}

/// Cargo takes a watched path that does not exist as changed on every build,
/// so the crate would rebuild on every `cargo run`.
#[test]
fn the_build_script_watches_only_files_that_exist_with_or_without_packed_refs() {
    let repo = TempDir::new("git-no-packed-refs");
    git(repo.path(), &["init", "-q"]);
    std::fs::write(repo.path().join("build.rs"), "").expect("write");
    // Unborn branch: no ref at all yet.
    for p in watched(repo.path()) {
        assert!(
            p.exists(),
            "watched but missing before the first commit: {}",
            p.display()
        );
    }
    git(repo.path(), &["add", "build.rs"]);
    git(repo.path(), &["commit", "-q", "-m", "one"]);
    assert!(!repo.path().join(".git/packed-refs").exists());
    let loose = watched(repo.path());
    assert!(
        loose.iter().any(|p| p.ends_with("refs/heads/main")),
        "{loose:?}"
    );
    for p in &loose {
        assert!(
            p.exists(),
            "watched but missing without packed-refs: {}",
            p.display()
        );
    }
    git(repo.path(), &["pack-refs", "--all"]);
    let packed = watched(repo.path());
    assert!(
        packed.iter().any(|p| p.ends_with("packed-refs")),
        "{packed:?}"
    );
    for p in &packed {
        assert!(
            p.exists(),
            "watched but missing with packed-refs: {}",
            p.display()
        );
    }
}

/// The `cargo run --release -- ARGS` commands of README.md's code blocks, as
/// argument lists for the `sonarnet` binary.
fn readme_commands() -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(crate::util::root().join("README.md")).expect("README.md");
    text.lines()
        .filter_map(|l| l.trim().strip_prefix("cargo run --release -- "))
        .map(|rest| {
            let cmd = rest.split("  #").next().unwrap_or(rest);
            cmd.split_whitespace().map(str::to_string).collect()
        })
        .collect()
}

/// Every command README shows runs, from a fresh directory, and holds its
/// scenario's `[expect]` (a failing check prints `FAILS:`; `--check` also
/// exits 1).
#[test]
fn every_command_readme_shows_runs_and_holds_its_expect() {
    let cmds = readme_commands();
    assert!(cmds.len() >= 10, "README shows {} commands", cmds.len());
    let dir = TempDir::new("readme-commands");
    std::os::unix::fs::symlink(
        crate::util::root().join("scenarios"),
        dir.path().join("scenarios"),
    )
    .expect("link scenarios/");
    for args in &cmds {
        let start = std::time::Instant::now();
        let mut child = Command::new(env!("CARGO_BIN_EXE_sonarnet"))
            .args(args)
            .current_dir(dir.path())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("spawn sonarnet");
        // Watchdog: no README command may hang the suite.
        let limit = std::time::Duration::from_secs(300);
        let out = loop {
            if child.try_wait().expect("wait").is_some() {
                break child.wait_with_output().expect("output");
            }
            if start.elapsed() > limit {
                let _ = child.kill();
                panic!("watchdog: `sonarnet {}` ran over {limit:?}", args.join(" "));
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "`sonarnet {}` exited {:?}\n{stdout}\n{stderr}",
            args.join(" "),
            out.status.code()
        );
        assert!(
            !stdout.contains("FAILS:"),
            "`sonarnet {}` fails its [expect]:\n{stdout}",
            args.join(" ")
        );
    }
}

/// The acoustic spiral's base variant is realtime with 60 s samples: in wall
/// time on node processes that is 100 minutes, so with no engine flag it runs
/// in virtual time.
#[test]
fn a_long_realtime_scenario_with_no_engine_flag_runs_in_virtual_time_in_seconds() {
    let out_dir = TempDir::new("acoustic-default-engine");
    let out = crate::util::run_file(
        &crate::util::scenario("mourya2017-spiral-acoustic.toml"),
        out_dir.path(),
        &["--variant", "ideal", "--samples", "12"],
        std::time::Duration::from_secs(120),
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("inprocess"), "{stdout}");
}

/// Asked for in wall time, the same run is announced with its estimate and
/// the flag that makes it fast, before it starts (the run itself is not
/// waited for: the note comes first, and the child is stopped).
#[test]
fn a_run_that_would_take_minutes_of_wall_time_says_so_before_it_starts() {
    let out_dir = TempDir::new("acoustic-wall-note");
    let mut child = Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args(["run"])
        .arg(crate::util::scenario("mourya2017-spiral-acoustic.toml"))
        .args(["--variant", "ideal", "--engine", "processes", "--out"])
        .arg(out_dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn sonarnet");
    let mut stderr = child.stderr.take().expect("stderr");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        use std::io::Read;
        let mut buf = [0u8; 4096];
        let mut text = String::new();
        while let Ok(n) = stderr.read(&mut buf) {
            if n == 0 {
                break;
            }
            text.push_str(&String::from_utf8_lossy(&buf[..n]));
            if text.contains('\n') {
                break;
            }
        }
        let _ = tx.send(text);
    });
    let first = rx
        .recv_timeout(std::time::Duration::from_secs(60))
        .unwrap_or_default();
    let _ = child.kill();
    let _ = child.wait();
    assert!(first.contains("1.7 h"), "{first}");
    assert!(first.contains("--engine inprocess"), "{first}");
}

fn refused(args: &[&str]) -> String {
    let out = crate::util::sonarnet(args, std::time::Duration::from_secs(60));
    assert_eq!(out.status.code(), Some(2), "{args:?}: {out:?}");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_point_of_another_dimension_is_refused_with_exit_2_naming_its_key() {
    let dir = TempDir::new("three-d");
    let text = std::fs::read_to_string(crate::util::scenario("mourya2017-spiral.toml"))
        .expect("read")
        .replace("[1500.0, -1000.0],", "[1500.0, -1000.0, -50.0],");
    let file = dir.write("mixed.toml", &text);
    let err = refused(&["validate", file.to_str().expect("utf-8")]);
    assert!(err.contains("geometry.receivers[1]"), "{err}");
    assert!(
        err.contains("has 3 coordinates but the scenario is 2-D"),
        "{err}"
    );
    let spiral = crate::util::scenario("mourya2017-spiral.toml");
    let spiral = spiral.to_str().expect("utf-8");
    let err = refused(&[
        "run",
        spiral,
        "--set",
        "geometry.transmitters=[[0,0,0],[1,1,1]]",
    ]);
    assert!(err.contains("geometry.transmitters[0]"), "{err}");
    let err = refused(&["run", spiral, "--set", "target.motion.center=[1]"]);
    assert!(err.contains("expected 2 or 3 coordinates, got 1"), "{err}");
    let err = refused(&["run", spiral, "--set", "target.motion.dz=-1"]);
    assert!(
        err.contains("target.motion.dz") && err.contains("3-D"),
        "{err}"
    );
}

#[test]
fn a_3d_scenario_validates_and_runs_as_3d_and_the_2d_library_reader_says_how_to_read_it() {
    let dir = TempDir::new("three-d");
    let file = dir.write("helix.toml", &crate::util::spiral_3d());
    let f = file.to_str().expect("utf-8");
    let out = crate::util::sonarnet(&["validate", f], std::time::Duration::from_secs(60));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{out:?}");
    assert!(stdout.contains("ok (3-D, 6 receivers"), "{stdout}");
    let run = dir.path().join("run");
    let out = crate::util::run_file(
        &file,
        &run,
        &["--engine", "inprocess", "--samples", "12", "--quiet"],
        std::time::Duration::from_secs(60),
    );
    assert!(out.status.success(), "{out:?}");
    assert!(run.join("depth.svg").is_file());
    let e = sonarnet::scenario::Scenario::load(&file).expect_err("a 2-D reader");
    assert_eq!(e.location.as_deref(), Some("geometry.receivers"));
    assert!(e.reason.contains("AnyScenario"), "{e}");
    // A 2-D u in a 3-D scenario is named.
    let bad = dir.write(
        "bad-u.toml",
        &crate::util::spiral_3d()
            .replace("init_u = [0.0, 0.0, 0.0, 0.0]", "init_u = [0.0, 0.0, 0.0]"),
    );
    let err = refused(&["validate", bad.to_str().expect("utf-8")]);
    assert!(
        err.contains("algorithm.init_u") && err.contains("[x, y, z, d]"),
        "{err}"
    );
}

#[test]
fn a_channel_key_set_without_a_channel_says_that_channel_model_must_be_set() {
    let spiral = crate::util::scenario("mourya2017-spiral.toml");
    let err = refused(&[
        "run",
        spiral.to_str().expect("utf-8"),
        "--set",
        "channel.bit_rate=500",
    ]);
    assert!(err.contains("channel.model"), "{err}");
    assert!(err.contains("acoustic"), "{err}");
}

#[test]
fn a_negative_or_fractional_seed_is_refused_saying_what_a_seed_is() {
    let spiral = crate::util::scenario("mourya2017-spiral.toml");
    let spiral = spiral.to_str().expect("utf-8");
    for bad in [
        ["--seed", "-1"],
        ["--seed=-1", ""],
        ["--seed", "1.5"],
        ["--seed", "x"],
    ] {
        let mut args = vec!["run", spiral];
        args.extend(bad.iter().filter(|a| !a.is_empty()));
        let err = refused(&args);
        assert!(
            err.contains("a seed is an integer in [0, 2^64)"),
            "{bad:?}: {err}"
        );
    }
}

#[test]
fn two_targets_or_a_list_of_motions_are_refused_saying_one_target_is_supported() {
    let dir = TempDir::new("targets");
    let text =
        std::fs::read_to_string(crate::util::scenario("mourya2017-spiral.toml")).expect("read");
    let target = text
        .lines()
        .skip_while(|l| !l.starts_with("[target]"))
        .skip(1)
        .take_while(|l| !l.starts_with('['))
        .collect::<Vec<_>>()
        .join("\n");
    let two = text.replace("[target]", "[[target]]") + &format!("\n[[target]]\n{target}\n");
    let file = dir.write("two.toml", &two);
    let err = refused(&["validate", file.to_str().expect("utf-8")]);
    assert!(err.contains("one target"), "{err}");
    let listed = text
        .replace("motion = {", "motion = [{")
        .replace("dt = 0.25 }", "dt = 0.25 }]");
    let file = dir.write("list.toml", &listed);
    let err = refused(&["validate", file.to_str().expect("utf-8")]);
    assert!(err.contains("one target"), "{err}");
}

#[test]
fn list_names_the_built_in_scenarios_from_any_directory_and_new_copies_one_out() {
    let dir = TempDir::new("list-anywhere");
    let out = Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .arg("list")
        .current_dir(dir.path())
        .output()
        .expect("run list");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    for name in sonarnet::scenario::shipped::names() {
        assert!(
            text.contains(&format!("{name}.toml")),
            "{name} missing:\n{text}"
        );
    }
    let out = Command::new(env!("CARGO_BIN_EXE_sonarnet"))
        .args(["new", "copy.toml", "--from", "mourya2017-spiral-faults"])
        .current_dir(dir.path())
        .output()
        .expect("run new --from");
    assert!(out.status.success(), "{out:?}");
    let copied = std::fs::read_to_string(dir.path().join("copy.toml")).expect("copy.toml");
    let shipped = std::fs::read_to_string(crate::util::scenario("mourya2017-spiral-faults.toml"))
        .expect("shipped");
    assert_eq!(copied, shipped);
    let err = refused(&["new", "x.toml", "--from", "no-such"]);
    assert!(
        err.contains("--from") && err.contains("mourya2017-spiral"),
        "{err}"
    );
}

#[test]
fn run_help_groups_its_flags_and_hides_what_the_build_cannot_do() {
    let out = crate::util::sonarnet(&["run", "--help"], std::time::Duration::from_secs(30));
    let help = String::from_utf8_lossy(&out.stdout);
    for heading in [
        "Scenario:",
        "Algorithm:",
        "Engine and clock:",
        "Faults:",
        "Evaluation:",
        "Output:",
    ] {
        assert!(help.contains(heading), "no {heading} in:\n{help}");
    }
    assert!(help.contains("--png"), "{help}");
    assert_eq!(
        help.contains("--zenoh-config"),
        cfg!(feature = "zenoh"),
        "{help}"
    );
}

/// `sonarnet new`'s defaults track: on a ring of 10 receivers the
/// distributed estimate stays within 3x of the centralised ML after burn-in.
#[test]
fn a_scaffolded_ten_receiver_ring_tracks_within_three_times_ml_at_its_defaults() {
    let dir = TempDir::new("new-defaults");
    let file = dir.path().join("ten.toml");
    let out = crate::util::sonarnet(
        &[
            "new",
            file.to_str().expect("utf-8"),
            "--receivers",
            "circle:10:1500",
            "--network",
            "ring",
            "--motion",
            "spiral",
        ],
        std::time::Duration::from_secs(60),
    );
    assert!(out.status.success(), "{out:?}");
    let sc = sonarnet::scenario::Scenario::from_file(&file).expect("the scaffold validates");
    let run = sc.run(&sonarnet::pipeline::RunOptions::inprocess());
    let rmse = run.metrics.rmse_after_burn_in.expect("rmse after burn-in");
    let ml = run.metrics.ml_rmse.expect("ml rmse");
    assert!(rmse < 3.0 * ml, "theta_bar {rmse} m against ML {ml} m");
}
