"""``python -m backend serve``: run the ground station (``openapi``: write its API document).

Every flag is also a ``VISLAND_*`` environment variable (a flag wins over the env).
With no ``--mavlink`` the in-process ArduCopter stand-in flies; with no ``--camera``
the simulated camera renders the pad from the vehicle's reported pose.
"""

from __future__ import annotations

import argparse
import logging
import socket
import sys
from pathlib import Path

from pydantic import ValidationError

from backend.datadir import prepare_data_dir
from backend.settings import Settings, resolve_token

# flag -> (settings field, type, help)
_FLAGS: dict[str, tuple[str, type, str]] = {
    "--host": ("host", str, "address to bind (default 127.0.0.1: this machine only)"),
    "--port": ("port", int, "dashboard/API port (default 8000)"),
    "--viser-port": (
        "viser_port",
        int,
        "loopback port of the 3D view's own server, reached through the station at "
        "/view3d/ (default 8080; 0 turns the 3D view off)",
    ),
    "--allowed-hosts": (
        "allowed_hosts",
        str,
        "host names the station answers to besides its own, comma-separated "
        "(e.g. gcs.local,192.168.1.20)",
    ),
    "--allowed-origins": (
        "allowed_origins",
        str,
        "browser origins allowed besides the station's own, comma-separated "
        "(e.g. https://gcs.example:8443 for a reverse proxy)",
    ),
    "--max-upload-pixels": (
        "max_upload_pixels",
        int,
        "largest picture accepted, in pixels (default 40000000)",
    ),
    "--mavlink": (
        "mavlink",
        str,
        "vehicle connection, e.g. tcp:127.0.0.1:5760, "
        "udpin:0.0.0.0:14550, /dev/ttyUSB0,57600 (default: the stand-in)",
    ),
    "--camera": ("camera", str, "sim | cmucam4:PORT | opencv:SOURCE (default sim)"),
    "--camera-calibration": ("camera_calibration", str, "OpenCV calibration file"),
    "--camera-mount": (
        "camera_mount",
        str,
        "the camera's turn from looking straight down, picture top to the nose: "
        "roll,pitch,yaw in degrees, as the vehicle's (default 0,0,0; or as last set "
        "from the dashboard)",
    ),
    "--sim-camera-mount": (
        "sim_camera_mount",
        str,
        "where the simulated camera truly sits, when not on the mount the station is "
        "told (default: that one, as it is at start)",
    ),
    "--reference": ("reference", str, "picture of the pad, cropped to its edge"),
    "--pad-size": ("pad_size", float, "pad width in metres (default 0.55)"),
    "--data-dir": ("data_dir", str, "where the database, token and flights live (./data)"),
    "--token": ("token", str, "operator token (default: generated, kept in DATA_DIR/token)"),
    "--sim-ready-after": ("sim_ready_after", float, "stand-in readiness time scale (1 = SITL)"),
    "--sim-speedup": ("sim_speedup", float, "stand-in clock speed-up"),
    "--pad-north": ("pad_north", float, "pad centre north of home, m"),
    "--pad-east": ("pad_east", float, "pad centre east of home, m"),
    "--pad-heading": ("pad_heading_deg", float, "where the pad picture's top faces, deg"),
    "--verifier-views": (
        "verifier_views",
        int,
        "views the pattern verifier of a reference learns from (default 1000; 0: off)",
    ),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m backend", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    serve = sub.add_parser("serve", help="run the ground station")
    for flag, (field, kind, text) in _FLAGS.items():
        serve.add_argument(flag, dest=field, type=kind, default=None, help=text)
    serve.add_argument(
        "--view-requires-token",
        dest="view_requires_token",
        action="store_true",
        default=None,
        help="viewing (GET, WebSocket) needs the token too",
    )
    serve.add_argument("--log-level", default="info", choices=["debug", "info", "warning"])
    doc = sub.add_parser(
        "openapi", help="write the OpenAPI document (no server is started): make types"
    )
    doc.add_argument("out", nargs="?", default="-", help="file to write (default: stdout)")
    return parser


def write_openapi(out: str) -> int:
    """The OpenAPI document as stable JSON text, to ``out`` ("-": stdout)."""
    import json

    from backend.app import create_app

    app = create_app(Settings())
    text = json.dumps(app.openapi(), indent=2, sort_keys=True, ensure_ascii=False) + "\n"
    if out == "-":
        sys.stdout.write(text)
    else:
        with open(out, "w", encoding="utf-8") as fh:
            fh.write(text)
    return 0


def settings_from_args(args: argparse.Namespace) -> Settings:
    """Settings from the environment, with the flags that were given on top."""
    given = {
        field: getattr(args, field)
        for field, _, _ in [*_FLAGS.values(), ("view_requires_token", bool, "")]
        if getattr(args, field, None) is not None
    }
    return Settings(**given)


def port_is_free(host: str, port: int) -> bool:
    """Whether a server could listen on ``host:port`` now (checked before starting)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


def _token_line(token: str, path: Path | None) -> str:
    """The banner's token line: the token itself only on the operator's terminal, never
    into a pipe or a file, where it would sit in a log."""
    where = f"kept in {path}" if path else "as given on the command line or environment"
    if sys.stdout.isatty():
        return f"{token}  ({where})"
    return f"not printed here (not a terminal): {where}"


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "openapi":
        return write_openapi(args.out)
    try:
        settings = settings_from_args(args)
    except ValidationError as exc:
        for err in exc.errors():
            where = ".".join(str(p) for p in err["loc"])
            print(f"error: {where}: {err['msg'].removeprefix('Value error, ')}", file=sys.stderr)
        return 2

    # The 3D view's own server listens on loopback only: browsers reach it through the station.
    ports = (
        ("--port", settings.host, settings.port),
        ("--viser-port", "127.0.0.1", settings.viser_port),
    )
    for flag, host, port in ports:
        if port and not port_is_free(host, port):
            print(f"error: {host}:{port} is in use: choose another with {flag}", file=sys.stderr)
            return 2

    import uvicorn
    from threadpoolctl import threadpool_limits

    from backend.api.security import install_log_redaction
    from backend.app import SERVER_OPTIONS, create_app
    from backend.viewer3d import browsable_host

    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    # The vision's many small matrix products: a BLAS on every core only waits on itself.
    threadpool_limits(1, user_api="blas")
    prepare_data_dir(settings.data_dir)
    token, token_path = resolve_token(settings)
    install_log_redaction(token)
    settings = settings.model_copy(update={"token": token})
    app = create_app(settings)
    base = f"http://{browsable_host(settings.host)}:{settings.port}"
    lines = [
        f"Visland ground station {'(stand-in vehicle)' if settings.mavlink is None else ''}",
        f"  dashboard  {base}  (enter the operator token there)",
    ]
    if settings.viser_port:
        lines.append(f"  3D view    {base}/view3d/")
    lines += [f"  token      {_token_line(token, token_path)}", f"  data       {settings.data_dir}"]
    if settings.host not in ("127.0.0.1", "localhost", "::1"):
        lines.append(
            f"  warning    listening on {settings.host}: reachable from the network; "
            "commands still need the token"
        )
    print("\n".join(lines), flush=True)
    uvicorn.run(
        app,
        host=settings.host,
        port=settings.port,
        log_level=args.log_level,
        **SERVER_OPTIONS,  # type: ignore[arg-type]
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
