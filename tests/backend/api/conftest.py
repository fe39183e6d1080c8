"""Fixtures shared by the API tests (helpers live in support.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from tests.backend.api.support import in_process, make_settings


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> Iterator[TestClient]:
    """The app in-process with its station running (stand-in vehicle, sim camera)."""
    settings = make_settings(tmp_path_factory.mktemp("data"), max_upload_bytes=1_000_000)
    with in_process(settings) as c:
        yield c
