//! The Python package's tests, run by README's one test command: this
//! target makes cargo build the extension module (`lib_sonarnet.so`, next
//! to this test's executable), assembles the package `sonarnet` around it
//! in `target/`, makes a virtual environment there with what the tests
//! import (numpy, pandas, tqdm, pytest, matplotlib: from PyPI on the first
//! run, then reused), and runs `pytest python/tests` against the command
//! line built by the same command (`target/<profile>/sonarnet`).
//!
//! `pip install ./python` builds the same extension through maturin; this
//! test loads the one the test command has just built, so that the suite
//! costs no second build.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

/// What the tests and the example import.
const REQUIREMENTS: &[&str] = &["numpy", "pandas", "tqdm", "pytest", "matplotlib"];

/// No Python test may hang the suite.
const WATCHDOG: Duration = Duration::from_secs(20 * 60);

/// The name a filter of `cargo test FILTER` is matched against.
const NAME: &str = "python_package_pytest_suite";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.iter().any(|a| a == "--list") {
        println!("{NAME}: test");
        return ExitCode::SUCCESS;
    }
    let filters: Vec<&String> = args.iter().filter(|a| !a.starts_with('-')).collect();
    if !filters.is_empty() && !filters.iter().any(|f| NAME.contains(f.as_str())) {
        println!("python tests: filtered out");
        return ExitCode::SUCCESS;
    }
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("python tests: FAILED: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let exe = std::env::current_exe().map_err(|e| format!("current_exe: {e}"))?;
    // target/<profile>/deps/pytest-HASH
    let deps = exe.parent().ok_or("no deps directory")?;
    let profile = deps.parent().ok_or("no profile directory")?;
    let target = profile.parent().ok_or("no target directory")?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or("no repository root")?
        .to_path_buf();
    let module = deps.join("lib_sonarnet.so");
    if !module.exists() {
        return Err(format!("{} was not built", module.display()));
    }
    let cli = profile.join("sonarnet");
    if !cli.exists() {
        return Err(format!(
            "{} was not built: run the workspace's tests (cargo test --release --workspace)",
            cli.display()
        ));
    }
    let venv = venv(target)?;
    let pkg = assemble(target, &root, &module)?;
    let python = venv.join("bin").join("python");
    let mut cmd = Command::new(&python);
    cmd.args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-ra"])
        .arg(root.join("python").join("tests"))
        .current_dir(&root)
        .env("PYTHONPATH", &pkg)
        .env("SONARNET_CLI", &cli)
        .env("SONARNET_ROOT", &root)
        .env("MPLBACKEND", "Agg")
        .env_remove("SONARNET_NODE_BIN")
        .stdin(Stdio::null());
    println!("+ PYTHONPATH={} {cmd:?}", pkg.display());
    let status = wait_with_watchdog(cmd)?;
    if !status.success() {
        return Err(format!("pytest exited with {status}"));
    }
    if std::env::var_os("SONARNET_TEST_PIP_INSTALL").is_some_and(|v| v == "1") {
        pip_install(target, &root)?;
    }
    Ok(())
}

/// README's install line, `pip install ./python`, into a fresh virtual
/// environment (maturin builds the wheel: a second release build of the
/// library, so only when `$SONARNET_TEST_PIP_INSTALL` is 1, as CI sets
/// it), then a run on node processes from the installed package and its
/// `sonarnet-node` command.
fn pip_install(target: &Path, root: &Path) -> Result<(), String> {
    let dir = target.join("python-pip-venv");
    new_venv(&dir)?;
    let mut cmd = Command::new(dir.join("bin").join("pip"));
    cmd.args(["install", "--disable-pip-version-check", "./python"])
        .current_dir(root)
        .stdin(Stdio::null());
    println!("+ {cmd:?}");
    let status = wait_with_watchdog(cmd)?;
    if !status.success() {
        return Err(format!("pip install ./python exited with {status}"));
    }
    let check = "import sonarnet, shutil, sys, os\n\
        r = sonarnet.Scenario.builtin('mourya2017-spiral').with_overrides({'target.samples': 20}).run(engine='processes', seed=1)\n\
        assert r.status == 'ok' and len(r.track) == 20, r\n\
        node = os.path.join(os.path.dirname(sys.executable), 'sonarnet-node')\n\
        assert os.access(node, os.X_OK), node\n\
        print('installed', sonarnet.__version__, 'ran on node processes')\n";
    let mut cmd = Command::new(dir.join("bin").join("python"));
    cmd.args(["-c", check])
        .current_dir(target)
        .env_remove("PYTHONPATH")
        .env_remove("SONARNET_NODE_BIN")
        .stdin(Stdio::null());
    let status = wait_with_watchdog(cmd)?;
    let _ = std::fs::remove_dir_all(&dir);
    if status.success() {
        Ok(())
    } else {
        Err(format!("the installed package failed its check ({status})"))
    }
}

/// The test environment `target/python-test-venv`, made once with
/// [`REQUIREMENTS`] and reused while they stay the same.
fn venv(target: &Path) -> Result<PathBuf, String> {
    let dir = target.join("python-test-venv");
    let marker = dir.join("sonarnet-requirements.txt");
    let want = REQUIREMENTS.join("\n");
    if std::fs::read_to_string(&marker).is_ok_and(|t| t == want) {
        return Ok(dir);
    }
    new_venv(&dir)?;
    let pip = dir.join("bin").join("pip");
    let ok = Command::new(&pip)
        .args(["install", "--quiet", "--disable-pip-version-check"])
        .args(REQUIREMENTS)
        .status()
        .map_err(|e| format!("cannot run {}: {e}", pip.display()))?;
    if !ok.success() {
        return Err(format!(
            "pip install {} failed (the first run needs PyPI)",
            REQUIREMENTS.join(" ")
        ));
    }
    std::fs::write(&marker, want).map_err(|e| format!("{}: {e}", marker.display()))?;
    Ok(dir)
}

/// A fresh virtual environment at `dir` (`$PYTHON`, default `python3`).
fn new_venv(dir: &Path) -> Result<(), String> {
    let _ = std::fs::remove_dir_all(dir);
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&python)
        .args(["-m", "venv"])
        .arg(dir)
        .status()
        .map_err(|e| {
            format!("cannot run {python} (Python 3 is needed for the Python tests): {e}")
        })?;
    if ok.success() {
        Ok(())
    } else {
        Err(format!("{python} -m venv {} failed", dir.display()))
    }
}

/// The package as the wheel lays it out: `python/sonarnet/*` with the
/// extension module as `sonarnet/_sonarnet.abi3.so`.
fn assemble(target: &Path, root: &Path, module: &Path) -> Result<PathBuf, String> {
    let pkg = target.join("python-test-package");
    let dest = pkg.join("sonarnet");
    let _ = std::fs::remove_dir_all(&dest);
    std::fs::create_dir_all(&dest).map_err(|e| format!("{}: {e}", dest.display()))?;
    let src = root.join("python").join("sonarnet");
    for entry in std::fs::read_dir(&src).map_err(|e| format!("{}: {e}", src.display()))? {
        let p = entry.map_err(|e| e.to_string())?.path();
        if p.is_file() {
            let to = dest.join(p.file_name().ok_or("file name")?);
            std::fs::copy(&p, &to).map_err(|e| format!("{}: {e}", p.display()))?;
        }
    }
    let to = dest.join("_sonarnet.abi3.so");
    std::fs::copy(module, &to).map_err(|e| format!("{}: {e}", module.display()))?;
    Ok(pkg)
}

/// Run `cmd`, killing it if it outlives [`WATCHDOG`].
fn wait_with_watchdog(mut cmd: Command) -> Result<std::process::ExitStatus, String> {
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot start pytest: {e}"))?;
    let start = Instant::now();
    loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            return Ok(s);
        }
        if start.elapsed() > WATCHDOG {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "pytest ran longer than {WATCHDOG:?} and was killed"
            ));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}
