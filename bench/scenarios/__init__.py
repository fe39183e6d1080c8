"""Scenario runner: missions flown many times against the stand-in (or any vehicle).

``python -m bench.scenarios land --runs 20 --seed 1 [--strategy plnd|guided]
[--wind 3] [--json] [--mavlink URL]``
"""

from bench.scenarios.land import RunResult, RunSpec, run_one, summarize

__all__ = ["RunResult", "RunSpec", "run_one", "summarize"]
