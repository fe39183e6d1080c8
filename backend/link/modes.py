"""ArduCopter flight modes: the custom_mode numbers a quadrotor firmware really has.

pymavlink's ``mode_mapping_acm`` also lists numbers that ArduCopter 4.5 answers with
"No such mode" on a quad (8, 10, 12, 26, 29); they are deliberately absent here so the
ground station never offers a mode the vehicle cannot enter.
"""

from __future__ import annotations

from types import MappingProxyType

#: custom_mode number -> mode name, exactly the modes of ArduCopter 4.5.6 on a quad.
COPTER_MODES: MappingProxyType[int, str] = MappingProxyType(
    {
        0: "STABILIZE",
        1: "ACRO",
        2: "ALT_HOLD",
        3: "AUTO",
        4: "GUIDED",
        5: "LOITER",
        6: "RTL",
        7: "CIRCLE",
        9: "LAND",
        11: "DRIFT",
        13: "SPORT",  # not compiled into every build; the vehicle refuses it where absent
        14: "FLIP",
        15: "AUTOTUNE",
        16: "POSHOLD",
        17: "BRAKE",
        18: "THROW",
        19: "AVOID_ADSB",
        20: "GUIDED_NOGPS",
        21: "SMART_RTL",
        22: "FLOWHOLD",
        23: "FOLLOW",
        24: "ZIGZAG",
        25: "SYSTEMID",
        27: "AUTO_RTL",
        28: "TURTLE",
    }
)

_BY_NAME: dict[str, int] = {name: number for number, name in COPTER_MODES.items()}


def mode_name(number: int | None) -> str | None:
    """Return the ArduCopter mode name for a custom_mode number, or None if unknown.

    >>> mode_name(4)
    'GUIDED'
    >>> mode_name(8) is None
    True
    """
    if number is None:
        return None
    return COPTER_MODES.get(int(number))


def mode_number(name: str) -> int:
    """Return the custom_mode number for a mode name (case-insensitive).

    Raises
    ------
    ValueError
        If ``name`` is not an ArduCopter mode; the message lists the valid ones.

    >>> mode_number("loiter")
    5
    """
    if not isinstance(name, str):
        raise ValueError(f"name must be a mode name string, got {type(name).__name__}")
    key = name.strip().upper()
    if key not in _BY_NAME:
        raise ValueError(
            f"name {name!r} is not an ArduCopter mode; valid modes: {valid_modes_text()}"
        )
    return _BY_NAME[key]


def valid_modes_text() -> str:
    """Comma-separated list of the mode names, in custom_mode order."""
    return ", ".join(COPTER_MODES.values())
