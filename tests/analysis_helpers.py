"""Small studies on built-in analytic problems for the analysis, views and CLI tests."""

from __future__ import annotations

from pathlib import Path

from vectorid import Study
from vectorid.demos.g12 import study_toml
from vectorid.spec import load_study


def make_store(
    folder: Path, problem: str = "binh-korn", trials: int = 512, limits: dict | None = None
) -> Path:
    """Run ``problem`` for ``trials`` serial trials into ``folder/<problem>.db``."""
    folder.mkdir(parents=True, exist_ok=True)
    toml = folder / f"{problem}.toml"
    toml.write_text(study_toml(problem, trials=trials, limits=limits), encoding="utf-8")
    path = folder / f"{problem}.db"
    with Study.create(load_study(toml), path) as st:
        st.run(executor="serial")
    return path
