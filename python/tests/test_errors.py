"""Errors raise typed exceptions with the command line's messages; Ctrl-C
stops a run in order and keeps what it completed."""

import os
import signal
import time

import pytest

import sonarnet
from conftest import cli, python, scenario


def test_the_exception_types_are_the_documented_subclasses():
    assert issubclass(sonarnet.ScenarioError, ValueError)
    assert issubclass(sonarnet.RunError, RuntimeError)
    assert issubclass(sonarnet.RunInterrupted, KeyboardInterrupt)


def test_a_missing_file_is_a_scenario_error_naming_it(tmp_path):
    with pytest.raises(sonarnet.ScenarioError) as e:
        sonarnet.Scenario.from_file(tmp_path / "nope.toml")
    assert "nope.toml" in str(e.value) and "cannot read scenario" in str(e.value)


def test_a_bad_key_in_a_file_gives_the_command_lines_message(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(scenario("mourya2017-spiral.toml").read_text().replace("samples = 100", "samples = -4"))
    with pytest.raises(sonarnet.ScenarioError) as e:
        sonarnet.Scenario.from_file(bad)
    err = cli("validate", bad, expect=2).stderr
    assert str(e.value) in err
    assert e.value.file == str(bad)
    assert e.value.reason in str(e.value)


def test_a_bad_override_names_the_key_as_set_does():
    sc = sonarnet.Scenario.builtin("mourya2017-spiral")
    with pytest.raises(sonarnet.ScenarioError) as e:
        sc.with_overrides({"algorithm.gamma": -1.0})
    assert "algorithm.gamma" in str(e.value)
    err = cli("run", scenario("mourya2017-spiral.toml"), "--set", "algorithm.gamma=-1.0", expect=2).stderr
    assert str(e.value) in err
    with pytest.raises(sonarnet.ScenarioError, match="no_such_key|unknown"):
        sc.with_overrides({"algorithm.no_such_key": 1})


@pytest.mark.parametrize(
    "kwargs,arg",
    [
        ({"engine": "warp"}, "engine"),
        ({"clock": "sundial"}, "clock"),
        ({"mode": "both"}, "mode"),
        ({"baselines": ["ogd", "nope"]}, "baselines"),
        ({"stall_timeout_s": 0.0}, "stall_timeout_s"),
        ({"transport": "zenoh"}, "transport"),
    ],
)
def test_a_bad_argument_is_a_scenario_error_naming_it(kwargs, arg):
    sc = sonarnet.Scenario.builtin("mourya2017-spiral")
    with pytest.raises(sonarnet.ScenarioError) as e:
        sc.run(**kwargs)
    assert e.value.key == arg, str(e.value)


def test_an_unknown_variant_lists_the_variants():
    with pytest.raises(sonarnet.ScenarioError, match="modem"):
        sonarnet.Scenario.from_file(scenario("mourya2017-spiral-acoustic.toml"), variant="nope")


def test_a_node_program_that_cannot_start_is_a_run_error_holding_the_partial_run(monkeypatch):
    monkeypatch.setenv("SONARNET_NODE_BIN", "/nonexistent/sonarnet-node")
    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 20})
    with pytest.raises(sonarnet.RunError) as e:
        sc.run(engine="processes")
    assert "/nonexistent/sonarnet-node" in str(e.value)
    assert e.value.run.status == "failed"
    assert len(e.value.run.track) == 0


def test_a_results_directory_that_cannot_be_written_is_refused_before_the_run(tmp_path):
    f = tmp_path / "file"
    f.write_text("")
    with pytest.raises(sonarnet.ScenarioError) as e:
        sonarnet.Scenario.builtin("mourya2017-spiral").run(engine="inprocess", out=f)
    assert e.value.key == "out"


CTRL_C = """
import sonarnet, sys
sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({{"target.samples": 100000}})
said = []
def ready(done, text):
    if not said:
        said.append(done)
        print("started", flush=True)
bar = ready
try:
    sc._s.run(engine={engine!r}, seed=1, progress=bar, out={out!r})
except sonarnet.RunInterrupted as e:
    run = sonarnet.Run(e.run)
    print("interrupted", run.status, len(run.track), flush=True)
    sys.exit(0)
print("completed", flush=True)
"""


@pytest.mark.parametrize("engine", ["inprocess", "processes"])
def test_ctrl_c_stops_the_run_in_order_and_keeps_the_completed_samples(engine, tmp_path):
    out_dir = tmp_path / "out"
    p = python(CTRL_C.format(engine=engine, out=str(out_dir)))
    try:
        line = p.stdout.readline()
        assert line.strip() == "started", line + p.stderr.read()
        time.sleep(0.5)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err
    words = out.split()
    assert words[:2] == ["interrupted", "interrupted"], out + err
    assert 0 < int(words[2]) < 100000
    # The results directory asked for holds the same samples, marked.
    written = sonarnet.load_results(out_dir)
    assert written.metrics["status"] == "interrupted"
    assert len(written.track) == int(words[2])


def test_a_run_after_an_interrupted_one_starts_afresh():
    # The stop request of Ctrl-C is cleared once the run has ended.
    code = CTRL_C.format(engine="inprocess", out=None).replace(
        'sys.exit(0)',
        'again = sc.with_overrides({"target.samples": 20}).run(engine="inprocess")\n'
        '    print(again.status, len(again.track), flush=True)\n    sys.exit(0)',
    )
    p = python(code)
    try:
        assert p.stdout.readline().strip() == "started"
        time.sleep(0.3)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err
    assert out.splitlines()[-1] == "ok 20", out + err


def test_nothing_is_left_in_shared_memory_after_runs_from_python():
    before = set(os.listdir("/dev/shm"))
    sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 20})
    sc.run(engine="processes")
    left = {n for n in set(os.listdir("/dev/shm")) - before if "iox2" in n or "sonarnet" in n}
    assert not left, left


SWEEP_CTRL_C = """
import sonarnet, sys
sc = sonarnet.Scenario.builtin("mourya2017-spiral").with_overrides({"target.samples": 2000})
said = []
def ready(done, text):
    if not said:
        said.append(done)
        print("started", flush=True)
bar = sonarnet._Bar(False, 0, "runs")
bar.callback = lambda: ready
sonarnet._Bar = lambda *a: bar
try:
    sonarnet.sweep(sc, grid={"algorithm.gamma": [1e-8, 2e-8, 5e-8, 1e-7]}, seeds=range(50), jobs=1)
except sonarnet.RunInterrupted as e:
    print("interrupted", len(e.sweep), flush=True)
    sys.exit(0)
print("completed", flush=True)
"""


def test_ctrl_c_stops_a_sweep_and_keeps_the_completed_runs():
    p = python(SWEEP_CTRL_C)
    try:
        assert p.stdout.readline().strip() == "started", p.stderr.read()
        time.sleep(0.3)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 0, err
    words = out.split()
    assert words[0] == "interrupted", out + err
    assert 0 < int(words[1]) < 200
