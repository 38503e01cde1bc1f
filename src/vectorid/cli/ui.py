"""The ``vectorid ui`` verb (loaded by :mod:`vectorid.cli`)::

    vectorid ui STORE [OTHER] [--host 127.0.0.1] [--port 8050]
                      [--executor serial|processes] [--workers N] [--max-points N]

Serves the browser UI of a study store; needs the ``ui`` extra (dash). With a second store,
a *Compare* tab shows the two models side by side (the same criteria on the same data).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .main import add_executor_options, add_store_argument, positive_int

__all__ = ["COMMANDS", "add_parsers"]


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number, got {text!r}") from None
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"expected a port in 1..65535, got {value}")
    return value


def add_parsers(sub: Any) -> None:
    """Add ``ui`` to the ``vectorid`` sub-parsers."""
    u = sub.add_parser("ui", help="serve the interactive browser UI of a study store")
    add_store_argument(u)
    u.add_argument(
        "other",
        nargs="?",
        help="a second store to compare with (two models of the same data: a Compare tab)",
    )
    u.add_argument(
        "--host",
        default="127.0.0.1",
        help="interface to bind (default 127.0.0.1; anything else is reachable by others)",
    )
    u.add_argument("--port", type=_port, default=8050, help="port (default 8050)")
    add_executor_options(u, scheduler=False, timeout=False)  # for the runs started from the UI
    u.add_argument(
        "--max-points",
        type=positive_int,
        default=20_000,
        help="points drawn in the criterion plot (default 20000; more are decimated)",
    )


def _cmd_ui(args: argparse.Namespace) -> int:
    from ..errors import StoreError

    path = Path(args.store)
    for p in (path, Path(args.other)) if args.other else (path,):
        if p.is_dir():
            stores = sorted(q.name for q in p.glob("*.db"))[:5]
            raise StoreError(
                f"{p} is a folder, not a study store; point to the .db file"
                + (f" (this folder holds {', '.join(stores)})" if stores else " (it holds none)")
            )
        if not p.is_file():
            raise StoreError(
                f"no store at {p}; run a study first (`vectorid demo`, `vectorid run STUDY.toml`)"
            )
    import importlib.util

    from .._hints import install_hint
    from ..errors import StudyDefinitionError

    missing = [m for m in ("dash", "plotly") if importlib.util.find_spec(m) is None]
    if missing:
        raise StudyDefinitionError(
            "ui",
            f"the browser UI needs {' and '.join(missing)}, which is not installed",
            install_hint("ui"),
        )
    from ..views.ui import serve

    try:
        serve(
            str(path),
            host=args.host,
            port=args.port,
            executor=args.executor,
            workers=args.workers,
            max_points=args.max_points,
            compare=args.other,
        )
    except ImportError as exc:  # pragma: no cover - a broken dash installation only
        raise StudyDefinitionError("ui", str(exc)) from None
    except KeyboardInterrupt:
        return 130
    except OSError as exc:  # port in use, cannot bind
        raise StudyDefinitionError(
            "--port", f"cannot serve on {args.host}:{args.port}: {exc}", "choose another --port"
        ) from None
    return 0


COMMANDS = {"ui": _cmd_ui}
