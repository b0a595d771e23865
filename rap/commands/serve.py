"""``rap-farm serve``: the planning service over HTTP (Ray Serve + FastAPI, ``rap.serve.http_app``).

Keeps the CNN and a pool of simulation actors warm and answers ``POST /plan`` with the document
``rap-farm plan --out`` writes. Binds to 127.0.0.1 unless ``--host`` says otherwise; any other
address needs a bearer token (``--token`` or ``RAP_FARM_TOKEN``), else it refuses to start (exit
status 2). Runs until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import os
from pathlib import Path

import typer

from rap.errors import InputError

__all__ = ["register", "serve_command"]


def serve_command(
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on (anything but "
                             "loopback needs --token)."),
    port: int = typer.Option(8000, "--port", min=1, max=65535, help="TCP port."),
    model: Path = typer.Option(None, "--model", help="CNN checkpoint [default: the shipped model]."),
    address: str = typer.Option(None, "--address", help="Run on this Ray cluster (HOST:PORT or "
                                "auto) [default: $RAY_ADDRESS, else a local Ray]."),
    token: str = typer.Option(None, "--token", help="Bearer token clients must send [default: "
                              "$RAP_FARM_TOKEN]."),
    workers: int = typer.Option(None, "--workers", min=1, help="Simulation actors [default: every "
                                "CPU of the cluster]."),
    trials: int = typer.Option(100, "--trials", min=1, help="Simulator trials per operation."),
    cache: Path = typer.Option(None, "--cache", help="Score cache file [default: "
                               "~/.cache/rap-farm/scores.json or $RAP_CACHE]."),
    no_cache: bool = typer.Option(False, "--no-cache", help="Keep scores in memory only."),
    budget: float = typer.Option(120.0, "--budget", min=0.001, max=600.0, help="A request's time "
                                 "budget in seconds when it names none (its budget_s, at most "
                                 "600): the search answers the best plan found within it."),
    engine: str = typer.Option("auto", "--engine", help="The CNN's scorer: auto (the default "
                               "scorer, as rap-farm plan's), cnn or torch (the CNN alone)."),
):
    """Serve plans over HTTP: GET /health, POST /plan, docs at /docs."""
    from rap.commands._console import console as make_console
    from rap.commands.plan import resolve_model
    from rap.plan.scoring.cache import default_cache_path

    err = make_console(stderr=True)
    token = token if token is not None else (os.environ.get("RAP_FARM_TOKEN") or None)
    model_path, _ = resolve_model(model, "rap", lambda s: err.print(
        s.replace("Planning with --method sim (simulator only) instead",
                  "Requests for method rap will be refused")))
    cache_path = None if no_cache else (cache or default_cache_path())
    from rap.serve.api import ServeConfig

    config = ServeConfig(host=host, port=port, model_path=model_path, workers=workers,
                         cache_path=str(cache_path) if cache_path else None, token=token,
                         trials=trials, request_budget_s=budget, engine=engine)
    config.check()  # before starting Ray: a refused configuration costs nothing
    if address is not None and not address.strip():
        raise InputError("--address: empty")
    from rap.serve.launch import run_service

    run_service(config, address=address, echo=lambda s: err.print(s, highlight=False))


def register(app: typer.Typer) -> None:
    app.command("serve")(serve_command)
