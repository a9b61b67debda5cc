"""Runs from Python give the command line's numbers, bit for bit."""

import json

import numpy as np
import pandas as pd
import pytest

import sonarnet
from conftest import cli, read, scenario

# (file, variant, extra command-line flags, the same as run() keywords)
CASES = [
    ("mourya2017-spiral.toml", None, [], {}),
    ("mourya2017-spiral.toml", None, ["--mode", "sync"], {"mode": "sync"}),
    ("mourya2017-spiral-acoustic.toml", "modem", [], {}),
    ("mourya2017-spiral-faults.toml", "crash", [], {}),
    ("mourya2017-spiral-3d.toml", None, [], {}),
]


@pytest.mark.parametrize("file,variant,flags,kwargs", CASES, ids=lambda c: str(c))
def test_python_and_the_command_line_write_identical_tables(tmp_path, file, variant, flags, kwargs):
    cli_dir = tmp_path / "cli"
    args = ["run", scenario(file), "--engine", "inprocess", "--seed", "3", "--set", "target.samples=30", "--quiet", "--out", cli_dir]
    if variant:
        args += ["--variant", variant]
    cli(*args, *flags)
    sc = sonarnet.Scenario.from_file(scenario(file), variant=variant).with_overrides({"target.samples": 30})
    run = sc.run(engine="inprocess", seed=3, **kwargs)
    assert run.status == "ok"
    tables = run.tables
    for name in ("track", "nodes", "messages", "faults", "schedule", "measurements", "truth"):
        path = cli_dir / f"{name}.csv"
        assert path.exists() == (name in tables), name
        if path.exists():
            pd.testing.assert_frame_equal(read(path), tables[name], check_exact=True, obj=name)
    metrics = json.loads((cli_dir / "metrics.json").read_text())
    for key in ("rmse", "rmse_after_burn_in", "status"):
        assert run.metrics.get(key) == metrics.get(key), key


def test_written_results_are_byte_identical_to_the_command_lines(tmp_path):
    cli(
        "run", scenario("mourya2017-spiral.toml"), "--engine", "inprocess", "--seed", "5",
        "--quiet", "--out", tmp_path / "cli",
    )
    run = sonarnet.Scenario.from_file(scenario("mourya2017-spiral.toml")).run(engine="inprocess", seed=5)
    run.write(tmp_path / "py")
    for name in ("track.csv", "nodes.csv", "schedule.csv", "measurements.csv", "truth.csv", "metrics.json"):
        a = (tmp_path / "cli" / name).read_text()
        b = (tmp_path / "py" / name).read_text()
        if name == "metrics.json":
            # The wall time is the only number that is not the run's own.
            a, b = (json.loads(x) for x in (a, b))
            for m in (a, b):
                m.pop("wall_seconds", None)
        assert a == b, name
    for plot in ("error.svg", "tracks.svg"):
        assert (tmp_path / "py" / plot).stat().st_size > 0


def test_node_processes_started_from_python_give_the_in_process_numbers():
    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 20})
    a = sc.run(engine="processes", seed=2)
    b = sc.run(engine="inprocess", seed=2)
    assert a.engine == "processes"
    pd.testing.assert_frame_equal(a.track, b.track, check_exact=True)
    pd.testing.assert_frame_equal(a.nodes, b.nodes, check_exact=True)


def test_overrides_follow_the_rules_of_set(tmp_path):
    cli(
        "run", scenario("mourya2017-spiral.toml"), "--engine", "inprocess", "--quiet",
        "--set", "algorithm.gamma=1e-7", "--set", "target.samples=40", "--set", "algorithm.mode=sync",
        "--out", tmp_path,
    )
    sc = sonarnet.Scenario.from_file(scenario("mourya2017-spiral.toml")).with_overrides(
        {"algorithm.gamma": 1e-7, "target.samples": 40, "algorithm.mode": "sync"}
    )
    assert sc.samples == 40
    assert sc.overrides == ["algorithm.gamma=1e-07", "target.samples=40", "algorithm.mode=sync"]
    run = sc.run(engine="inprocess")
    pd.testing.assert_frame_equal(read(tmp_path / "track.csv"), run.track, check_exact=True)


def test_lists_and_tables_are_written_as_toml():
    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides(
        {"geometry.transmitters": [[0.0, 0.0], [1000, 0]], "algorithm.burn_in": 5}
    )
    assert "geometry.transmitters=[[0.0, 0.0], [1000, 0]]" in sc.overrides


def test_a_sweep_gives_the_command_lines_sweep_table(tmp_path):
    cli(
        "sweep", scenario("mourya2017-spiral.toml"), "--grid", "algorithm.gamma=1e-8,1e-7",
        "--seeds", "0..1", "--set", "target.samples=20", "--quiet", "--out", tmp_path / "cli",
    )
    sc = sonarnet.Scenario.from_file(scenario("mourya2017-spiral.toml")).with_overrides({"target.samples": 20})
    df = sonarnet.sweep(sc, grid={"algorithm.gamma": ["1e-8", "1e-7"]}, seeds=range(2), jobs=2, out=tmp_path / "py")
    want = read(tmp_path / "cli" / "sweep.csv")
    assert len(df) == 4
    assert list(df.columns) == list(want.columns)
    timing = [c for c in df.columns if "wall" in c or "per_sample_ms" in c]
    pd.testing.assert_frame_equal(df.drop(columns=timing), want.drop(columns=timing), check_exact=True)


def test_a_sweep_takes_numbers_as_grid_values_and_cleans_its_temporary_directory():
    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 20})
    df = sonarnet.sweep(sc, grid={"algorithm.iterations_per_sample": [5, 20]}, seeds=[1], jobs=1)
    assert list(df["algorithm.iterations_per_sample"]) == [5, 20]
    assert (df["status"] == "ok").all()


def test_monte_carlo_trials_are_the_command_lines(tmp_path):
    cli(
        "run", scenario("mourya2017-spiral.toml"), "--trials", "3", "--set", "target.samples=20",
        "--quiet", "--out", tmp_path / "cli",
    )
    sc = sonarnet.Scenario.from_file(scenario("mourya2017-spiral.toml")).with_overrides({"target.samples": 20})
    run = sc.run(trials=3)
    assert len(run.trials) == 3
    want = read(tmp_path / "cli" / "trials.csv")
    timing = [c for c in want.columns if "wall" in c]
    pd.testing.assert_frame_equal(run.trials.drop(columns=timing), want.drop(columns=timing), check_exact=True)
    assert run.summary["trials"] == 3


def test_float_columns_are_numpy_arrays_that_share_the_librarys_memory():
    run = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 20}).run(engine="inprocess")
    err = run._n.table("track")[2]["error"]
    assert isinstance(err, np.ndarray) and err.dtype == np.float64
    # Owned by the Rust vector it was built from: no copy was made.
    assert not err.flags.owndata
    assert run.track["error"].dtype == np.float64


def test_a_three_dimensional_run_has_depth_columns():
    run = sonarnet.Scenario.builtin("mourya2017-spiral-3d").with_overrides({"target.samples": 20}).run(engine="inprocess")
    assert {"true_z", "est_z", "ml_z"} <= set(run.track.columns)
    assert "z" in run.nodes.columns


def test_the_package_lists_the_built_in_scenarios_and_its_version():
    names = sonarnet.list_scenarios()
    assert "mourya2017-spiral" in names
    assert sonarnet.__version__ == cli("--version").stdout.split()[-1]
    for name in names:
        assert sonarnet.Scenario.builtin(name).name


def test_help_reads_well():
    doc = sonarnet.Scenario.run.__doc__
    for word in ("engine", "seed", "variant", "RunInterrupted", "progress"):
        assert word in doc
    assert sonarnet.sweep.__doc__ and sonarnet.Run.__doc__


def test_the_spiral_example_draws_both_figures(tmp_path):
    import subprocess
    import sys

    from conftest import ROOT

    p = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "python" / "spiral.py"), str(tmp_path)],
        capture_output=True, text=True, timeout=600, cwd=ROOT,
    )
    assert p.returncode == 0, p.stderr
    for f in ("fig2a.png", "fig2b.png"):
        assert (tmp_path / f).stat().st_size > 10_000
    rmse = {" ".join(l.split()[:2]): float(l.split()[-2]) for l in p.stdout.splitlines() if "rmse" in l}
    # The paper's point: the quadratic constraint is what makes eq. (5) track.
    assert rmse["sync gtrs"] * 3 < rmse["sync relaxed"], p.stdout


def _python_blocks(markdown):
    blocks, cur = [], None
    for line in markdown.splitlines():
        if cur is None and line.strip() == "```python":
            cur = []
        elif cur is not None and line.strip() == "```":
            blocks.append("\n".join(cur))
            cur = None
        elif cur is not None:
            cur.append(line)
    return blocks


@pytest.mark.parametrize("doc", ["README.md", "docs/src/python.md"])
def test_the_python_code_of_the_readme_and_the_book_runs(tmp_path, monkeypatch, doc):
    import matplotlib

    matplotlib.use("Agg")
    from conftest import ROOT

    (tmp_path / "scenarios").symlink_to(ROOT / "scenarios")
    monkeypatch.chdir(tmp_path)
    blocks = _python_blocks((ROOT / doc).read_text())
    assert blocks, doc
    env = {}
    for code in blocks:
        exec(compile(code.replace("seeds=range(5)", "seeds=range(2)"), doc, "exec"), env)


def test_a_run_releases_the_gil():
    import threading
    import time

    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 3000})
    done = threading.Event()
    result = {}

    def work():
        result["run"] = sc.run(engine="inprocess", progress=False)
        done.set()

    t = threading.Thread(target=work)
    t.start()
    spins = 0
    while not done.is_set():
        spins += 1  # Python code running beside the run
        time.sleep(0.001)
    t.join()
    assert result["run"].status == "ok"
    assert spins > 50, spins
