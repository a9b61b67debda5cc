"""sonarnet from Python: run scenarios and sweeps, get pandas DataFrames.

sonarnet emulates a distributed multistatic sonar network whose receivers
track a target with randomized asynchronous Douglas-Rachford gossip (Mourya
et al., CAMSAP 2017), each local step an exact GTRS solve. This package is
the library itself, compiled into the extension ``sonarnet._sonarnet``: a
run from Python gives the command line's numbers bit for bit.

    >>> import sonarnet
    >>> sc = sonarnet.Scenario.builtin("mourya2017-spiral")
    >>> run = sc.with_overrides({"target.samples": 20}).run(engine="inprocess", seed=3)
    >>> run.metrics["status"]
    'ok'
    >>> run.track[["sample", "error"]].tail(1)  # doctest: +SKIP

A run releases the GIL; Ctrl-C stops it in order and raises
:class:`RunInterrupted` (a ``KeyboardInterrupt``) that holds the completed
samples. Bad input raises :class:`ScenarioError` (a ``ValueError``) with
the command line's message: the file, the key and the reason.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import shutil
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping, Optional, Sequence, Union

from . import _sonarnet as _native
from ._sonarnet import RunError, RunInterrupted, ScenarioError, __version__, list_scenarios

if TYPE_CHECKING:  # pandas is imported when a table is first asked for
    import pandas

__all__ = [
    "Scenario",
    "Run",
    "sweep",
    "load_results",
    "list_scenarios",
    "ScenarioError",
    "RunError",
    "RunInterrupted",
    "__version__",
]

PathLike = Union[str, "os.PathLike[str]"]

# The tables of a results directory, in the order the library writes them.
_TABLES = (
    "track",
    "nodes",
    "faults",
    "schedule",
    "messages",
    "iterations",
    "measurements",
    "truth",
    "receivers",
)


def _toml(value: Any) -> str:
    """A Python value as TOML text (inside a list or table)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        v = float(value)
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    if isinstance(value, Iterable):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise ScenarioError(f"<arguments>: cannot write {value!r} ({type(value).__name__}) as a scenario value")


def _value_text(value: Any) -> str:
    """A value as ``--set`` and ``--grid`` take it: a string as written
    (TOML, or a bare word such as ``sync``), anything else as TOML."""
    return value if isinstance(value, str) else _toml(value)


def _set_text(key: str, value: Any) -> str:
    """``KEY=VALUE`` as ``--set`` takes it."""
    return f"{key}={_value_text(value)}"


def _want_bar(progress: Optional[bool]) -> bool:
    if progress is not None:
        return bool(progress)
    try:
        tty = sys.stderr.isatty()
    except (AttributeError, ValueError):
        tty = False
    return tty or "ipykernel" in sys.modules


class _Bar:
    """The progress bar: tqdm (a widget in Jupyter, text on a terminal)."""

    def __init__(self, enabled: bool, total: int, unit: str):
        self._bar: Any = None
        if enabled:
            try:
                from tqdm.auto import tqdm
            except ImportError:  # tqdm is a dependency; a bare build still runs
                return
            self._bar = tqdm(total=total, unit=unit, dynamic_ncols=True)

    def __call__(self, done: int, text: str) -> None:
        if self._bar is not None:
            self._bar.n = done
            if text:
                self._bar.set_postfix_str(text, refresh=False)
            self._bar.refresh()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()

    def callback(self) -> "Optional[_Bar]":
        """The bar as the native run takes it: None when it draws nothing
        (the run then does not stop to report its progress)."""
        return self if self._bar is not None else None


def _frame(columns: Sequence[str], data: Mapping[str, Any]) -> "pandas.DataFrame":
    import pandas as pd

    if columns and len(data[columns[0]]) == 0:
        # A table with a header only: read_csv gives object columns.
        return pd.DataFrame({c: pd.Series([], dtype=object) for c in columns})
    return pd.DataFrame({c: data[c] for c in columns}, columns=list(columns), copy=False)


def _read_csv(path: Path) -> "pandas.DataFrame":
    import pandas as pd

    # The CSVs hold shortest round-trip decimals. Before pandas 3 the
    # default float parser could be one unit in the last place off;
    # pandas 3 parses exactly by default (and deprecates the argument).
    if int(pd.__version__.split(".")[0]) < 3:
        return pd.read_csv(path, float_precision="round_trip")
    return pd.read_csv(path)


class Scenario:
    """A validated scenario: a file's text, its overrides and a variant.

    Build one with :meth:`from_file`, :meth:`from_toml` or :meth:`builtin`;
    every key is checked exactly as ``sonarnet run`` checks it, and a bad
    one raises :class:`ScenarioError` naming the file, key and reason.
    Scenarios are immutable: :meth:`with_overrides` and :meth:`with_variant`
    return new ones.
    """

    __slots__ = ("_s",)

    def __init__(self, native: "_native._Scenario"):
        self._s = native

    @staticmethod
    def from_file(path: PathLike, variant: Optional[str] = None) -> "Scenario":
        """Read and validate a scenario file (its ``variant``, else its base
        or first variant). Relative file names in it are taken from its
        directory."""
        return Scenario(_native._Scenario.from_file(os.fspath(path), variant))

    @staticmethod
    def from_toml(text: str, path: Optional[PathLike] = None, variant: Optional[str] = None) -> "Scenario":
        """Validate scenario text. ``path`` names it in errors and anchors
        the relative file names in it (default ``<string>``: the working
        directory)."""
        p = None if path is None else os.fspath(path)
        return Scenario(_native._Scenario.from_toml(text, p, variant))

    @staticmethod
    def builtin(name: str, variant: Optional[str] = None) -> "Scenario":
        """A scenario built into sonarnet, by the name :func:`list_scenarios`
        gives (``"mourya2017-spiral"``)."""
        return Scenario(_native._Scenario.builtin(name, variant))

    def with_overrides(self, overrides: Mapping[str, Any]) -> "Scenario":
        """This scenario with keys overridden, by the rules of ``--set``:
        ``{"algorithm.gamma": 1e-7, "target.samples": 40, "faults[0].at_s": 2}``.
        Numbers, booleans, lists and dicts are written as TOML; a string is
        taken as ``--set`` takes it (TOML, else a bare word such as
        ``"sync"``; quote a string that looks like a number: ``'"7"'``).
        The result is validated as a file is."""
        sets = [_set_text(k, v) for k, v in overrides.items()]
        return Scenario(self._s.with_overrides(sets))

    def with_variant(self, name: str) -> "Scenario":
        """The file's variant ``name``, with this scenario's overrides."""
        return Scenario(self._s.with_variant(name))

    @property
    def name(self) -> str:
        """The scenario's name."""
        return self._s.name

    @property
    def path(self) -> str:
        """The file it came from (``<string>`` for text)."""
        return os.fspath(self._s.path)

    @property
    def variant(self) -> Optional[str]:
        """The variant chosen (None for a file without variants)."""
        return self._s.variant

    @property
    def variants(self) -> list:
        """Every variant of the file, in file order."""
        return self._s.variants

    @property
    def dim(self) -> int:
        """2 or 3."""
        return self._s.dim

    @property
    def seed(self) -> int:
        """The run seed."""
        return self._s.seed

    @property
    def samples(self) -> int:
        """How many samples a run has."""
        return self._s.samples

    @property
    def overrides(self) -> list:
        """The overrides applied, as ``KEY=VALUE`` texts."""
        return self._s.overrides

    @property
    def text(self) -> str:
        """The scenario text (before overrides)."""
        return self._s.text

    def describe(self) -> dict:
        """What ``sonarnet describe`` prints, as a dict."""
        return dict(self._s.describe())

    def warnings(self) -> list:
        """The warnings ``sonarnet run`` prints for this scenario."""
        return self._s.warnings()

    def run(
        self,
        engine: Optional[str] = None,
        seed: Optional[int] = None,
        variant: Optional[str] = None,
        *,
        mode: Optional[str] = None,
        clock: Optional[str] = None,
        baselines: Optional[Sequence[str]] = None,
        trials: Optional[int] = None,
        transport: Optional[str] = None,
        poll_us: int = 0,
        stall_timeout_s: float = 5.0,
        out: Optional[PathLike] = None,
        progress: Optional[bool] = None,
    ) -> "Run":
        """Run the scenario and score it, as ``sonarnet run`` does.

        Args:
            engine: ``"processes"`` (one OS process per receiver over
                iceoryx2), ``"inprocess"`` or ``"threads"``; default as the
                command line's (processes, or the discrete-event engine for
                long realtime runs).
            seed: the run seed (default: the scenario's).
            variant: run this variant of the file.
            mode: ``"sync"`` (Mourya 2017 eq. 5) or ``"async"`` (eq. 11).
            clock: ``"logical"`` or ``"realtime"`` (default: the scenario's).
            baselines: centralised references to run beside the gossip
                (``["ogd", "onm", "ls"]``; ``[]`` for none).
            trials: Monte Carlo trials over seeds ``seed .. seed+trials``
                (in-process); default: the scenario's ``[monte_carlo]``.
            transport: ``"iceoryx2"`` (the only one of the Python build).
            poll_us: node processes poll this long before blocking.
            stall_timeout_s: the liveness watchdog (0.1 to 3600 s).
            out: also write the results directory here (CSVs, JSON, plots),
                as ``sonarnet run --out`` does.
            progress: a progress bar (default: on a terminal or in Jupyter).

        Returns:
            The :class:`Run`, its metrics and tables in memory.

        Raises:
            ScenarioError: a bad argument or combination, before any work.
            RunError: the engine stopped early; ``e.run`` has what completed.
            RunInterrupted: Ctrl-C; ``e.run`` has what completed.
        """
        sc = self if variant is None else self.with_variant(variant)
        base = list(baselines) if baselines is not None else None
        n = trials if trials is not None else sc._s.trials
        if n is not None and n > 1:
            return sc._monte_carlo(n, seed, mode, clock, base, out, progress, engine)
        bar = _Bar(_want_bar(progress), sc.samples, "samples")
        try:
            native = sc._s.run(
                engine=engine,
                clock=clock,
                seed=seed,
                mode=mode,
                baselines=base,
                transport=transport,
                poll_us=poll_us,
                stall_timeout_s=stall_timeout_s,
                out=None if out is None else os.fspath(out),
                progress=bar.callback(),
            )
        except (RunError, RunInterrupted) as e:
            if getattr(e, "run", None) is not None:
                e.run = Run(e.run)
            raise
        finally:
            bar.close()
        return Run(native)

    def _monte_carlo(self, trials, seed, mode, clock, baselines, out, progress, engine) -> "Run":
        if engine not in (None, "inprocess"):
            raise ScenarioError(
                f"<arguments>: engine: Monte Carlo trials run in-process (engine={engine!r} was asked)"
            )
        keep = out is not None
        dest = Path(out) if keep else Path(tempfile.mkdtemp(prefix="sonarnet-mc-"))
        bar = _Bar(_want_bar(progress), trials, "trials")
        try:
            self._s.monte_carlo(
                trials,
                os.fspath(dest),
                seed=seed,
                mode=mode,
                baselines=baselines,
                clock=clock,
                progress=bar.callback(),
            )
            run = load_results(dest)
            if not keep:
                run._load_all()
                run._dir = None
            return run
        except RunInterrupted as e:
            e.run = load_results(dest)
            if not keep:
                e.run._load_all()
                e.run._dir = None
            raise
        finally:
            bar.close()
            if not keep:
                shutil.rmtree(dest, ignore_errors=True)

    def __repr__(self) -> str:
        return repr(self._s)


class Run:
    """A finished run: ``metrics`` (the metrics.json dict) and every table
    of the results directory as a pandas DataFrame with the CSV's columns
    and values (``track``, ``nodes``, ...; None when the run has no such
    table). Float columns are numpy arrays built from the library's own
    vectors."""

    def __init__(self, native: Any = None, directory: Optional[Path] = None):
        self._n = native
        self._dir = directory
        self._frames: Optional[dict] = None
        self._metrics: Optional[dict] = None
        self._extra: dict = {}

    # -- tables -------------------------------------------------------
    def _load_all(self) -> None:
        """Read a results directory's files (once)."""
        if self._frames is not None:
            return
        frames: dict = {}
        if self._dir is not None and self._n is None:
            for name in _TABLES + ("trials",):
                p = self._dir / f"{name}.csv"
                if p.exists():
                    frames[name] = _read_csv(p)
            for name in ("metrics", "summary"):
                p = self._dir / f"{name}.json"
                if p.exists():
                    self._extra[name] = json.loads(p.read_text())
        self._frames = frames

    def _names(self) -> list:
        if self._n is not None:
            return list(self._n.table_names())
        self._load_all()
        return list(self._frames or {})

    @property
    def tables(self) -> dict:
        """Every table the run has, by name (``track``, ``nodes``,
        ``schedule``, ``messages``, ``measurements``, ``truth``, ...)."""
        return {name: self._table(name) for name in self._names()}

    def _table(self, name: str) -> "Optional[pandas.DataFrame]":
        self._load_all()
        frames = self._frames if self._frames is not None else {}
        if name not in frames and self._n is not None:
            t = self._n.table(name)
            if t is not None:
                frames[name] = _frame(t[1], t[2])
        return frames.get(name)

    @property
    def track(self) -> "pandas.DataFrame":
        """track.csv: per sample the truth, ``theta_bar``, its error, the ML
        estimate, the CRLB, the CTTE and every baseline's columns."""
        return self._table("track")

    @property
    def nodes(self) -> "pandas.DataFrame":
        """nodes.csv: every node's ``theta`` after every sample."""
        return self._table("nodes")

    @property
    def messages(self) -> "Optional[pandas.DataFrame]":
        """messages.csv: every frame on the acoustic channel and its fate."""
        return self._table("messages")

    @property
    def faults(self) -> "Optional[pandas.DataFrame]":
        """faults.csv: every fault applied, its detection and recovery."""
        return self._table("faults")

    @property
    def trials(self) -> "Optional[pandas.DataFrame]":
        """trials.csv of a Monte Carlo run: a row per trial."""
        return self._table("trials")

    @property
    def schedule(self) -> "Optional[pandas.DataFrame]":
        """schedule.csv: the async gossip's edge schedule."""
        return self._table("schedule")

    @property
    def measurements(self) -> "pandas.DataFrame":
        """measurements.csv: every measurement, in the trace format."""
        return self._table("measurements")

    @property
    def truth(self) -> "Optional[pandas.DataFrame]":
        """truth.csv: the target's true position per sample."""
        return self._table("truth")

    # -- the rest -----------------------------------------------------
    @property
    def metrics(self) -> dict:
        """metrics.json's content."""
        if self._metrics is None:
            if self._n is not None:
                self._metrics = json.loads(self._n.metrics_json())
            else:
                self._load_all()
                self._metrics = self._extra.get("metrics", {})
        return self._metrics

    @property
    def summary(self) -> Optional[dict]:
        """summary.json of a Monte Carlo run (per-metric statistics over
        the trials, mean curves); None for a single run."""
        self._load_all()
        return self._extra.get("summary")

    @property
    def status(self) -> str:
        """``ok``, ``interrupted`` or ``failed``."""
        if self._n is not None:
            return self._n.status
        s = self.summary or self.metrics
        return str(s.get("status", "ok"))

    @property
    def error(self) -> Optional[str]:
        """Why the run stopped early (None when every sample ran)."""
        if self._n is not None:
            return self._n.error
        return self.metrics.get("error")

    @property
    def seed(self) -> Optional[int]:
        """The run seed."""
        if self._n is not None:
            return self._n.seed
        t = self.track
        return None if t is None or len(t) == 0 else int(t["seed"].iloc[0])

    @property
    def engine(self) -> Optional[str]:
        """The engine that ran it (``inprocess``, ``processes``, ``threads``)."""
        if self._n is not None:
            return self._n.engine
        return None

    @property
    def clock(self) -> Optional[str]:
        """The clock (``logical`` or ``realtime``)."""
        if self._n is not None:
            return self._n.clock
        return None

    @property
    def dir(self) -> Optional[Path]:
        """The results directory written with the run, if any."""
        if self._n is not None:
            d = self._n.dir
            return None if d is None else Path(d)
        return self._dir

    def write(self, dir: PathLike, plots: bool = True, png: bool = False) -> Path:
        """Write the results directory ``sonarnet run`` writes: run.json,
        the CSVs, metrics.json and (``plots``) the SVG plots."""
        if self._n is None:
            if self._dir is None:
                raise RunError("this run's results directory was temporary and is gone; run with out=")
            shutil.copytree(self._dir, dir, dirs_exist_ok=True)
            return Path(dir)
        self._n.write(os.fspath(dir), plots, png)
        return Path(dir)

    def __repr__(self) -> str:
        return f"Run(status={self.status!r}, seed={self.seed}, samples={0 if self.track is None else len(self.track)})"


def load_results(dir: PathLike) -> Run:
    """A results directory written by ``sonarnet run`` (or ``out=``) as a
    :class:`Run`: its CSVs read back exactly (round-trip float parsing)."""
    d = Path(dir)
    if not (d / "metrics.json").exists() and not (d / "summary.json").exists():
        raise ScenarioError(f"{d}: not a sonarnet results directory (no metrics.json)")
    return Run(directory=d)


def sweep(
    scenario: Scenario,
    grid: Mapping[str, Sequence[Any]],
    seeds: Optional[Iterable[int]] = None,
    jobs: Optional[int] = None,
    engine: str = "inprocess",
    out: Optional[PathLike] = None,
    progress: Optional[bool] = None,
) -> "pandas.DataFrame":
    """Run every point of ``grid`` at every seed, as ``sonarnet sweep``
    does, and return sweep.csv as a DataFrame: a row per run with its grid
    values, seed, status, ``[expect]`` counts and every metric.

    Args:
        scenario: the scenario (its overrides apply first).
        grid: ``{"algorithm.gamma": [1e-8, 1e-7], ...}``; values as in
            :meth:`Scenario.with_overrides`.
        seeds: the seeds (default: the scenario's).
        jobs: runs at once (default: the CPUs; 1 on node processes).
        engine: the engine of every run.
        out: keep the sweep's directory here (sweep.csv,
            sweep-summary.csv, a directory per run); default: a temporary
            one, removed.
        progress: a progress bar (default: on a terminal or in Jupyter).
    """
    if not grid:
        raise ScenarioError("<arguments>: grid: give at least one key with its values")
    axes = []
    for key, values in grid.items():
        if isinstance(values, (str, bytes)) or not isinstance(values, Iterable):
            raise ScenarioError(f"<arguments>: grid: {key}: give a list of values")
        texts = [_value_text(v) for v in values]
        axes.append((key, texts))
    seed_list = [scenario.seed] if seeds is None else [int(s) for s in seeds]
    if jobs is None:
        jobs = 1 if engine == "processes" else (os.cpu_count() or 1)
    keep = out is not None
    dest = Path(out) if keep else Path(tempfile.mkdtemp(prefix="sonarnet-sweep-"))
    total = len(seed_list)
    for _, v in axes:
        total *= len(v)
    bar = _Bar(_want_bar(progress), total, "runs")
    try:
        _native._sweep(scenario._s, axes, seed_list, int(jobs), engine, os.fspath(dest), bar.callback())
        return _read_csv(dest / "sweep.csv")
    except RunInterrupted as e:
        # The completed runs' rows were written before the exception.
        p = dest / "sweep.csv"
        e.sweep = _read_csv(p) if p.exists() else None
        raise
    finally:
        bar.close()
        if not keep:
            shutil.rmtree(dest, ignore_errors=True)
