"""Settings: env prefix, validation with sentences, the token file."""

from __future__ import annotations

import stat

import pytest
from pydantic import ValidationError

from backend.__main__ import build_parser, settings_from_args
from backend.settings import Settings, get_settings, resolve_token


def test_defaults_bind_loopback(monkeypatch):
    for key in ("VISLAND_HOST", "VISLAND_PORT", "VISLAND_MAVLINK"):
        monkeypatch.delenv(key, raising=False)
    s = Settings()
    assert s.host == "127.0.0.1" and s.port == 8000 and s.viser_port == 8080
    assert s.mavlink is None and s.camera == "sim" and s.pad_size == 0.55
    assert s.view_requires_token is False


def test_env_prefix(monkeypatch):
    monkeypatch.setenv("VISLAND_PORT", "9001")
    monkeypatch.setenv("VISLAND_MAVLINK", "tcp:127.0.0.1:5760")
    monkeypatch.setenv("VISLAND_VIEW_REQUIRES_TOKEN", "true")
    monkeypatch.setenv("VISLAND_PAD_SIZE", "1.2")
    s = Settings()
    assert (s.port, s.mavlink, s.view_requires_token, s.pad_size) == (
        9001,
        "tcp:127.0.0.1:5760",
        True,
        1.2,
    )


def test_blank_env_means_not_given(monkeypatch):
    monkeypatch.setenv("VISLAND_MAVLINK", "")
    assert Settings().mavlink is None
    # ... so that what the operator set at run time holds (docker-compose.yml's blanks)
    monkeypatch.setenv("VISLAND_CAMERA_MOUNT", "")
    monkeypatch.setenv("VISLAND_VIEW_REQUIRES_TOKEN", "")
    given = Settings().model_fields_set
    assert Settings().camera_mount == (0.0, 0.0, 0.0) and "camera_mount" not in given
    assert "view_requires_token" not in given


@pytest.mark.parametrize(
    ("field", "value", "words"),
    [
        ("pad_size", 0, "greater than 0"),
        ("pad_size", 25, "less than or equal to 20"),
        ("port", 70000, "less than or equal to 65535"),
        ("camera", "webcam", "camera must be"),
        ("camera", "opencv:", "needs a port"),
        ("camera", "cmucam4: ", "needs a port"),
        ("camera", "sim:3", "takes nothing"),
        ("reference", "/no/such/pad.png", "no file at"),
        ("camera_calibration", "/no/such/cal.yaml", "no file at"),
        ("token", "short", "at least 8"),
        ("signing_key", "zz", "hex"),
        ("jpeg_quality", 5, "greater than or equal to 10"),
        ("camera_mount", "0,10", "roll,pitch,yaw"),
        ("camera_mount", "a,b,c", "roll,pitch,yaw"),
        ("camera_mount", "0,60,0", "within 45 degrees"),
        ("camera_mount", "0,0,200", "within -180..180"),
        ("camera_mount", "nan,0,0", "finite"),
    ],
)
def test_bad_values_are_refused_with_a_reason(field, value, words):
    with pytest.raises(ValidationError, match=words):
        Settings(**{field: value})


def test_cli_flags_override_env(monkeypatch):
    monkeypatch.setenv("VISLAND_PORT", "9001")
    args = build_parser().parse_args(
        [
            "serve",
            "--port",
            "9002",
            "--viser-port",
            "0",
            "--mavlink",
            "udpin:0.0.0.0:14550",
            "--view-requires-token",
            "--pad-size",
            "0.8",
        ]
    )
    s = settings_from_args(args)
    assert (s.port, s.viser_port, s.mavlink, s.view_requires_token, s.pad_size) == (
        9002,
        0,
        "udpin:0.0.0.0:14550",
        True,
        0.8,
    )


def test_the_camera_mount_comes_from_the_environment_or_a_flag(monkeypatch):
    assert Settings().camera_mount == (0.0, 0.0, 0.0)
    monkeypatch.setenv("VISLAND_CAMERA_MOUNT", "1.5, -8, 90")
    assert Settings().camera_mount == (1.5, -8.0, 90.0)
    args = build_parser().parse_args(["serve", "--camera-mount", "0,12,180"])
    assert settings_from_args(args).camera_mount == (0.0, 12.0, 180.0)
    # The simulated camera sits where the station is told, unless put elsewhere.
    assert settings_from_args(args).sim_camera_mount is None
    args = build_parser().parse_args(["serve", "--sim-camera-mount", "0,8,0"])
    assert settings_from_args(args).sim_camera_mount == (0.0, 8.0, 0.0)
    with pytest.raises(ValidationError, match="within 45 degrees"):
        Settings(sim_camera_mount="50,0,0")


def test_get_settings_is_cached_and_overridable(monkeypatch):
    get_settings.cache_clear()
    monkeypatch.setenv("VISLAND_PORT", "9003")
    try:
        assert get_settings() is get_settings()
        assert get_settings().port == 9003
    finally:
        get_settings.cache_clear()


def test_token_generated_once_with_mode_0600(tmp_path):
    s = Settings(data_dir=tmp_path)
    token, path = resolve_token(s)
    assert path == tmp_path / "token" and len(token) >= 24
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    again, _ = resolve_token(s)
    assert again == token


def test_given_token_wins_and_is_not_written(tmp_path):
    token, path = resolve_token(Settings(data_dir=tmp_path, token="operator-secret"))
    assert token == "operator-secret" and path is None
    assert not (tmp_path / "token").exists()
