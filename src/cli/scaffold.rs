//! `sonarnet new`, `sonarnet list`, `sonarnet describe`.

use super::NewArgs;
use crate::cli::errors::CliError;
use crate::model::error::InputError;
use crate::scenario::scaffold::{Layout, MotionSpec, NetworkSpec, ScaffoldSpec};
use crate::scenario::shipped;
use crate::scenario::{AnyScenario, Scenario};
use std::path::Path;
use std::path::PathBuf;

pub(super) fn new_command(args: &NewArgs) -> Result<(), CliError> {
    if let Some(from) = &args.from {
        return copy_shipped(from, &args.file, args.force);
    }
    let receivers = args.receivers.as_deref().unwrap_or_default();
    let name = match &args.name {
        Some(n) => n.clone(),
        None => args
            .file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into()),
    };
    let spec = ScaffoldSpec {
        name,
        receivers: Layout::parse("--receivers", receivers)?,
        transmitters: args
            .transmitters
            .as_deref()
            .map(|t| Layout::parse("--transmitters", t))
            .transpose()?,
        network: NetworkSpec::parse(&args.network)?,
        motion: MotionSpec::parse(&args.motion)?,
        seed: args.seed,
    };
    let text = spec.to_toml()?;
    // What is written must validate: say which flag to change if not.
    let sc = Scenario::from_toml_str(&text, &args.file).map_err(|e| {
        let flag = match e.location.as_deref() {
            Some(l) if l.starts_with("network") => "--network",
            Some(l) if l.starts_with("geometry.transmitters") => "--transmitters",
            Some(l) if l.starts_with("geometry") => "--receivers",
            Some(l) if l.starts_with("target") => "--motion",
            _ => "<layout>",
        };
        InputError::at(
            Path::new("<command line>"),
            flag,
            format!(
                "the scenario would not validate: {}{}",
                e.location.map_or(String::new(), |l| format!("{l}: ")),
                e.reason
            ),
        )
    })?;
    write_new(&args.file, &text, args.force)?;
    println!(
        "wrote {} ({} receivers, {} transmitters, {} links, {} samples)",
        args.file.display(),
        sc.graph.len(),
        sc.geometry.transmitters.len(),
        sc.graph.edges().len(),
        sc.samples
    );
    println!("  run it:      sonarnet run {}", args.file.display());
    println!("  read it:     sonarnet describe {}", args.file.display());
    Ok(())
}

/// Write a new scenario file, refusing to overwrite one without `--force`.
fn write_new(file: &Path, text: &str, force: bool) -> Result<(), CliError> {
    if file.exists() && !force {
        return Err(InputError::file(file, "exists: choose another name, or --force").into());
    }
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| InputError::file(dir, format!("cannot create the directory: {e}")))?;
    }
    std::fs::write(file, text).map_err(|e| InputError::file(file, format!("cannot write: {e}")))?;
    Ok(())
}

/// `sonarnet new FILE --from NAME`: the built-in scenario's text, as shipped.
fn copy_shipped(name: &str, file: &Path, force: bool) -> Result<(), CliError> {
    let all = shipped::load(name)
        .map_err(|e| InputError::at(Path::new("<command line>"), "--from", e.reason))?;
    let text = shipped::text(name).unwrap_or_default();
    write_new(file, text, force)?;
    let variants: Vec<&str> = all.iter().filter_map(AnyScenario::variant).collect();
    println!(
        "wrote {} (a copy of the built-in {}{})",
        file.display(),
        name.strip_suffix(".toml").unwrap_or(name),
        if variants.is_empty() {
            String::new()
        } else {
            format!("; variants {}", variants.join(", "))
        }
    );
    println!("  run it:      sonarnet run {}", file.display());
    println!("  read it:     sonarnet describe {}", file.display());
    Ok(())
}

pub(super) fn list_command(dir: Option<&Path>) -> Result<(), CliError> {
    let Some(dir) = dir else {
        for (name, _) in shipped::SHIPPED {
            print_listed(&format!("{name}.toml"), shipped::load(name));
        }
        println!();
        println!("built in: copy one out with `sonarnet new FILE --from NAME`, or run it from");
        println!("a checkout as `sonarnet run scenarios/NAME.toml`");
        return Ok(());
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| InputError::file(dir, format!("cannot list scenarios: {e}")))?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        println!("no scenario files in {}", dir.display());
    }
    for p in &files {
        let file = p
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned());
        print_listed(&file, AnyScenario::load_all(p));
    }
    Ok(())
}

/// `names` after `head`, comma-separated, in lines of at most `width`
/// characters (a name longer than a line gets one of its own); the
/// continuation lines indented under the first name. None for no names.
fn wrap_names(head: &str, names: &[&str], width: usize) -> Vec<String> {
    let indent = " ".repeat(head.chars().count());
    let mut lines: Vec<String> = Vec::new();
    let mut cur = head.to_string();
    let mut empty = true;
    for (k, name) in names.iter().enumerate() {
        let comma = if k + 1 < names.len() { "," } else { "" };
        let piece = format!("{name}{comma}");
        if !empty && cur.chars().count() + 1 + piece.chars().count() > width {
            lines.push(std::mem::replace(&mut cur, indent.clone()));
            empty = true;
        }
        if !empty {
            cur.push(' ');
        }
        cur.push_str(&piece);
        empty = false;
    }
    if !names.is_empty() {
        lines.push(cur);
    }
    lines
}

/// One entry of `sonarnet list`: the file, its description and variants.
fn print_listed(file: &str, loaded: Result<Vec<AnyScenario>, InputError>) {
    match loaded {
        Ok(all) if !all.is_empty() => {
            println!("{file}");
            println!(
                "    {}{}",
                if all[0].dim() == 3 { "[3-D] " } else { "" },
                one_line(&all[0].file().description)
            );
            let variants: Vec<&str> = all.iter().filter_map(AnyScenario::variant).collect();
            for line in wrap_names("    variants: ", &variants, 120) {
                println!("{line}");
            }
        }
        Ok(_) => println!("{file}\n    (no scenario)"),
        Err(e) => println!("{file}\n    invalid: {e}"),
    }
}

pub(super) fn describe_command(
    file: &Path,
    variants: &[String],
    set: &[String],
) -> Result<(), CliError> {
    let overrides = set
        .iter()
        .map(|s| crate::scenario::Override::parse(s))
        .collect::<Result<Vec<_>, _>>()?;
    let all = AnyScenario::load_all_with(file, &overrides, variants)?;
    for v in variants {
        if !all.iter().any(|s| s.variant() == Some(v.as_str())) {
            return Err(InputError::at(
                Path::new("<command line>"),
                "--variant",
                format!("no variant {v:?} in {}", file.display()),
            )
            .into());
        }
    }
    let mut first = true;
    for sc in &all {
        if !variants.is_empty() && !variants.iter().any(|v| sc.variant() == Some(v.as_str())) {
            continue;
        }
        if !first {
            println!();
        }
        first = false;
        for (k, v) in sc.describe() {
            println!("{k:>13}  {v}");
        }
    }
    Ok(())
}

/// A description on one line, cut at a word to at most 110 characters.
fn one_line(desc: &str) -> String {
    let flat = desc.split_whitespace().collect::<Vec<_>>().join(" ");
    if flat.is_empty() {
        return "(no description)".into();
    }
    if flat.chars().count() <= 110 {
        return flat;
    }
    let mut out = String::new();
    for w in flat.split(' ') {
        if out.chars().count() + w.chars().count() + 1 > 108 {
            break;
        }
        if !out.is_empty() {
            out.push(' ');
        }
        out.push_str(w);
    }
    format!("{out} …")
}

#[cfg(test)]
mod wrap_tests {
    use super::wrap_names;

    #[test]
    fn variant_names_wrap_at_the_width_with_continuation_lines_indented() {
        let names = ["alpha", "beta", "gamma", "delta"];
        assert_eq!(
            wrap_names("  v: ", &names, 18),
            vec!["  v: alpha, beta,", "     gamma, delta"]
        );
        assert_eq!(
            wrap_names("  v: ", &names, 200),
            vec!["  v: alpha, beta, gamma, delta"]
        );
        assert!(wrap_names("  v: ", &[], 20).is_empty());
        // A name longer than the width gets a line of its own.
        assert_eq!(
            wrap_names("v: ", &["a", "much-too-long-a-name", "b"], 10),
            vec!["v: a,", "   much-too-long-a-name,", "   b"]
        );
    }
}
