"""The station on a real uvicorn server in a thread of this process (loopback), set up
for the fuzzers: a known operator token, a quick stand-in, uploads up to 2 MB."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from backend.loopback import LoopbackServer
from backend.settings import Settings

TOKEN = "fuzz-operator-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}


class Server(LoopbackServer):
    """``with Server(data_dir) as s:`` the station runs at ``s.url`` until the block ends."""

    def __init__(self, data_dir: Path, **overrides: Any) -> None:
        values: dict[str, Any] = {
            "data_dir": data_dir,
            "token": TOKEN,
            "viser_port": 0,
            "sim_ready_after": 0.1,
            "verifier_views": 0,
            "max_upload_bytes": 2_000_000,
        }
        values.update(overrides)
        super().__init__(Settings(**values), name="fuzz-uvicorn")
