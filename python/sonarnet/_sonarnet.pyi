"""Type stubs of the native module ``sonarnet._sonarnet`` (PyO3). Use the
package ``sonarnet``; these are its building blocks."""

from typing import Any, Callable, Optional, Sequence

__version__: str

class ScenarioError(ValueError):
    file: str
    key: Optional[str]
    reason: str

class RunError(RuntimeError):
    run: Any

class RunInterrupted(KeyboardInterrupt):
    run: Any

_Progress = Optional[Callable[[int, str], None]]

class _Scenario:
    @staticmethod
    def from_file(path: str, variant: Optional[str] = None) -> "_Scenario": ...
    @staticmethod
    def from_toml(text: str, path: Optional[str] = None, variant: Optional[str] = None) -> "_Scenario": ...
    @staticmethod
    def builtin(name: str, variant: Optional[str] = None) -> "_Scenario": ...
    def with_overrides(self, sets: Sequence[str]) -> "_Scenario": ...
    def with_variant(self, name: str) -> "_Scenario": ...
    name: str
    path: str
    variant: Optional[str]
    variants: list[str]
    dim: int
    seed: int
    samples: int
    trials: Optional[int]
    overrides: list[str]
    text: str
    def describe(self) -> list[tuple[str, str]]: ...
    def warnings(self) -> list[str]: ...
    def run(
        self,
        engine: Optional[str] = None,
        clock: Optional[str] = None,
        seed: Optional[int] = None,
        mode: Optional[str] = None,
        baselines: Optional[Sequence[str]] = None,
        transport: Optional[str] = None,
        poll_us: int = 0,
        stall_timeout_s: float = 5.0,
        out: Optional[str] = None,
        progress: _Progress = None,
    ) -> "_Run": ...
    def monte_carlo(
        self,
        trials: int,
        out: str,
        seed: Optional[int] = None,
        mode: Optional[str] = None,
        baselines: Optional[Sequence[str]] = None,
        clock: Optional[str] = None,
        progress: _Progress = None,
    ) -> bool: ...

class _Run:
    status: str
    error: Optional[str]
    seed: int
    engine: str
    clock: str
    dir: Optional[str]
    def metrics_json(self) -> str: ...
    def table_names(self) -> list[str]: ...
    def table(self, name: str) -> Optional[tuple[str, list[str], dict[str, Any]]]: ...
    def write(self, dir: str, plots: bool = True, png: bool = False) -> None: ...

def list_scenarios() -> list[str]: ...
def _sweep(
    scenario: _Scenario,
    axes: Sequence[tuple[str, Sequence[str]]],
    seeds: Sequence[int],
    jobs: int,
    engine: str,
    out: str,
    progress: _Progress = None,
) -> int: ...
def _bench_native(scenario: _Scenario, runs: int) -> float: ...
def _node_main(argv: Sequence[str]) -> int: ...
