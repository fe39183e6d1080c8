"""Comparing secrets: constant time, and total over every string a client can send."""

from __future__ import annotations

import secrets


def tokens_equal(given: str, expected: str) -> bool:
    """Constant-time comparison of any two strings (non-ASCII, lone surrogates too).

    >>> tokens_equal("s3cret-token", "s3cret-token"), tokens_equal("\\udcff", "x")
    (True, False)
    """
    return secrets.compare_digest(
        given.encode("utf-8", "surrogatepass"), expected.encode("utf-8", "surrogatepass")
    )
