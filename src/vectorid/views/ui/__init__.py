"""The browser UI of a study (``vectorid ui STORE``): test tables with criteria constraints
typed or dragged, linked criterion and parameter plots, a chosen trial with its sections and
robustness checks, double tuning with a new stage run in the background, and the study
overview.

Built with Dash (extra ``ui``) on top of :mod:`vectorid.analysis` and
:mod:`vectorid.views.figures`. The callbacks are plain functions
(:mod:`vectorid.views.ui.callbacks`), so they are tested and benchmarked without a browser.
"""

from __future__ import annotations

from typing import Any

__all__ = ["create_app", "serve"]

LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def create_app(*args: Any, **kwargs: Any) -> Any:
    """See :func:`vectorid.views.ui.app.create_app`."""
    from .app import create_app as _create

    return _create(*args, **kwargs)


def serve(
    store: str,
    *,
    host: str = "127.0.0.1",
    port: int = 8050,
    executor: str | None = None,
    workers: int | None = None,
    max_points: int = 20_000,
    compare: str | None = None,
) -> None:
    """Serve the UI of ``store`` until interrupted (Ctrl-C), then stop any running job.

    Parameters
    ----------
    store : path
        The study store.
    host : str
        Interface to bind; 127.0.0.1 unless you mean to expose the study (anyone who can
        reach the port can read it and start runs).
    port : int
    executor, workers
        For background run jobs.
    max_points : int
        Points drawn in the criterion-vs-criterion plot.
    compare : path, optional
        A second store: a *Compare* tab shows both models side by side.
    """
    import logging
    import sys

    from .data import limit_allocator_arenas, limit_blas_threads

    limit_allocator_arenas()
    app, ctx = create_app(
        store, executor=executor, workers=workers, max_points=max_points, compare=compare
    )
    limit_blas_threads(1)  # requests run in threads: BLAS threads on top oversubscribe
    if host not in LOCAL_HOSTS:
        print(
            f"warning: serving on {host}: anyone who can reach port {port} there can read this "
            "study and start runs on this machine; use the default 127.0.0.1 (and an SSH "
            "tunnel) unless that is what you want",
            file=sys.stderr,
        )
    logging.getLogger("werkzeug").setLevel(logging.WARNING)
    shown = f"[{host}]" if ":" in host else host
    print(
        f"vectorid ui: {ctx.cache.path} at http://{shown}:{port}/  (Ctrl-C to stop)",
        file=sys.stderr,
    )
    try:
        app.run(host=host, port=port, debug=False, threaded=True)
    finally:
        ctx.jobs.shutdown()
