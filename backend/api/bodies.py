"""The base of every request body: strict, whole, finite.

Strict: a JSON ``true`` is not a number and ``"5"`` is not 5 (a ``{"altitude_m": true}``
must not take off to 1 m). Whole: unknown fields are refused (a typo is not silently
ignored). Finite: no ``NaN`` or ``Infinity`` anywhere. The ranges are on each field.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class StrictBody(BaseModel):
    """A request body: no coercion, no unknown fields, no non-finite numbers."""

    model_config = ConfigDict(strict=True, extra="forbid", allow_inf_nan=False)
