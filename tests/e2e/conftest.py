"""The browser tests' fixtures (tests/e2e/support.py holds them and the helpers)."""

from tests.e2e.support import browser, page, station

__all__ = ["browser", "page", "station"]
