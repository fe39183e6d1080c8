"""The operator's dashboard end to end: real Chromium, a real uvicorn server, the
stand-in ArduCopter in its own process over real MAVLink TCP, the simulated camera.

Load the page, watch telemetry move, upload a reference, switch to GUIDED, arm and
take off through the confirmation dialogs, and see the link-lost alert when the
vehicle goes silent. Screenshots are kept under test-artifacts/ for a person to look at.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from tests.e2e.support import (
    DIST,
    NO_CHROMIUM,
    Station,
    expect,
    number_in,
    open_dashboard,
    retry_command,
    screenshot,
    send_command,
    start_station,
    stop_station,
)

pytestmark = [pytest.mark.e2e, pytest.mark.slow, NO_CHROMIUM]


def test_page_loads_with_every_panel(page, station: Station) -> None:
    open_dashboard(page, station)
    assert "Visland" in page.title()
    for testid in ("camera", "mission", "controls", "map", "viser", "view3d", "flight", "events"):
        expect(page.get_by_test_id(testid)).to_be_visible()
    expect(page.get_by_test_id("token-state")).to_have_text("token set")
    assert "token" not in page.url
    status = station.get("/api/status")[1]
    expect(page.get_by_test_id("viser-link")).to_have_attribute("href", status["viser_url"])
    page.get_by_test_id("viser-embed").click()
    expect(page.get_by_test_id("viser-frame")).to_have_attribute("src", status["viser_url"])
    expect(page.get_by_test_id("viser-legend")).to_be_visible()
    expect(page.get_by_test_id("camera-placeholder")).to_be_hidden(timeout=20_000)
    expect(page.get_by_test_id("pipeline-fps")).not_to_have_text("—", timeout=10_000)
    for tab, testid in (("params", "params"), ("flights", "flights"), ("reference", "reference")):
        page.get_by_test_id(f"tab-{tab}").click()
        expect(page.get_by_test_id(testid)).to_be_visible()
    assert not page.errors, page.errors


def test_telemetry_moves(page, station: Station) -> None:
    open_dashboard(page, station)
    expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=20_000)
    expect(page.get_by_test_id("strip-mode")).not_to_have_text("—")
    attitude = page.get_by_test_id("attitude-text")
    expect(attitude).not_to_contain_text("R —", timeout=10_000)
    first_att = attitude.inner_text()
    first_age = page.get_by_test_id("heartbeat-age").inner_text()
    deadline = time.monotonic() + 10
    changed = set()
    while time.monotonic() < deadline and len(changed) < 2:
        page.wait_for_timeout(300)
        if attitude.inner_text() != first_att:
            changed.add("attitude")
        if page.get_by_test_id("heartbeat-age").inner_text() != first_age:
            changed.add("heartbeat")
    assert changed == {"attitude", "heartbeat"}, f"did not move: {changed}"
    expect(page.get_by_test_id("strip-battery")).to_contain_text("V")
    assert not page.errors, page.errors


def test_server_connection_loss_shows_and_reconnect_restores_state(page, station: Station):
    open_dashboard(page, station)
    expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=20_000)
    expect(page.get_by_test_id("alerts")).to_be_hidden()  # the first connection is no alarm
    page.evaluate("window.visland.ws.stop()")
    expect(page.get_by_test_id("server-state")).to_have_text("server stopped")
    alert = page.get_by_test_id("alert").filter(has_text="Server connection lost")
    expect(alert).to_be_visible()
    expect(page.get_by_test_id("strip-link")).to_have_text("NO SERVER")
    page.evaluate("window.visland.ws.start()")
    expect(page.get_by_test_id("server-state")).to_have_text("server connected")
    expect(page.get_by_test_id("strip-link")).to_have_text("UP")
    expect(alert).to_have_attribute("data-active", "false")  # cleared, kept until acknowledged
    alert.get_by_test_id("alert-ack").click()
    expect(page.get_by_test_id("alerts")).to_be_hidden()
    assert not page.errors, page.errors


def test_reference_upload_shows_corners(page, station: Station, tmp_path: Path) -> None:
    import cv2

    from pipeline.render import make_pad_image
    from tests.pads import helipad, seen_at_a_slant

    picture = tmp_path / "my-pad.png"
    assert cv2.imwrite(str(picture), make_pad_image())
    open_dashboard(page, station, tab="reference")
    page.get_by_test_id("reference-file").set_input_files(str(picture))
    page.get_by_test_id("reference-size").fill("0.6")
    page.get_by_test_id("reference-upload").click()
    expect(page.get_by_test_id("reference-upload-state")).to_contain_text(
        "uploaded", timeout=15_000
    )
    expect(page.get_by_test_id("reference-name")).to_contain_text("my-pad")
    corners = page.get_by_test_id("reference-corners").locator("tr")
    expect(corners).to_have_count(12)
    xs = [number_in(corners.nth(i).locator("td").nth(1).inner_text()) for i in range(12)]
    assert all(x is not None and abs(x) <= 0.3 + 1e-9 for x in xs), xs
    active = station.get("/api/reference")[1]
    assert active["name"].startswith("my-pad") and active["pad_size_m"] == pytest.approx(0.6)
    meta = page.get_by_test_id("reference-meta")
    expect(meta).to_contain_text("3 other marks")  # (its rim and two side bars)
    expect(meta).not_to_contain_text("smaller H")
    # A pad with a painted HELIPAD: the letter H it tells apart from its own is said.
    assert cv2.imwrite(str(picture), helipad())
    page.get_by_test_id("reference-file").set_input_files(str(picture))
    page.get_by_test_id("reference-size").fill("1.0")
    page.get_by_test_id("reference-upload").click()
    expect(meta).to_contain_text("1 smaller H told apart from the pad's", timeout=15_000)
    outline = page.get_by_test_id("reference-outline")
    expect(outline).to_have_text("")
    # The default pad with ground around it: the dashboard says what its size is taken for.
    ground = np.full((720, 720, 3), (60, 120, 70), np.uint8)
    ground[60:660, 60:660] = make_pad_image(600)
    assert cv2.imwrite(str(picture), ground)
    page.get_by_test_id("reference-file").set_input_files(str(picture))
    page.get_by_test_id("reference-upload").click()
    expect(outline).to_contain_text("spans 83 % of it", timeout=15_000)
    expect(outline).to_contain_text("every distance would come 17 % short")
    slant = page.get_by_test_id("reference-slant")
    expect(slant).to_have_text("")
    # The pad seen 10 degrees off the vertical from a pad's width away: its H's legs
    # converge by 5 degrees, and the dashboard says the picture looks taken at a slant.
    assert cv2.imwrite(str(picture), seen_at_a_slant(10.0))
    page.get_by_test_id("reference-file").set_input_files(str(picture))
    page.get_by_test_id("reference-upload").click()
    expect(slant).to_contain_text("converge by 5.0 °", timeout=15_000)
    assert not page.errors, page.errors


def test_bad_upload_is_refused_and_the_reference_stays(page, station: Station, tmp_path: Path):
    before = station.get("/api/reference")[1]
    junk = tmp_path / "notes.png"
    junk.write_bytes(b"this is not a picture at all")
    open_dashboard(page, station, tab="reference")
    page.get_by_test_id("reference-file").set_input_files(str(junk))
    page.get_by_test_id("reference-upload").click()
    state = page.get_by_test_id("reference-upload-state")
    expect(state).to_contain_text("refused (415)")
    expect(state).to_contain_text("the previous reference stays active.")
    assert ".." not in state.inner_text()
    page.get_by_test_id("reference-size").fill("25")
    page.get_by_test_id("reference-upload").click()
    expect(state).to_contain_text("pad size must be")
    assert station.get("/api/reference")[1]["id"] == before["id"]


def test_commands_without_token_are_refused(page, station: Station) -> None:
    open_dashboard(page, station, token=None)
    expect(page.get_by_test_id("token-state")).to_have_text("no token: view only")
    text = send_command(page, "arm", confirm=True)
    assert text.startswith("Arm: not authorised:"), text
    expect(page.get_by_test_id("token-input")).to_have_class(re.compile("attention"))
    assert station.get("/api/telemetry")[1]["armed"] is False


def test_take_off_is_confirmed_and_happens(page, station: Station) -> None:
    open_dashboard(page, station)
    expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=20_000)
    # Arm asks first; Cancel leaves the vehicle alone
    page.get_by_test_id("arm").click()
    expect(page.get_by_test_id("confirm-dialog")).to_contain_text("the propellers start to spin")
    page.get_by_test_id("confirm-no").click()
    expect(page.get_by_test_id("strip-armed")).to_have_text("DISARMED")

    page.get_by_test_id("mode-select").select_option("GUIDED")
    retry_command(page, "set-mode", confirm=False, until="accepted", timeout=30)
    expect(page.get_by_test_id("strip-mode")).to_have_text("GUIDED", timeout=5_000)
    expect(page.get_by_test_id("strip-ready")).to_have_text(
        "ready to arm in GUIDED", timeout=30_000
    )
    retry_command(page, "arm", confirm=True, until="accepted", timeout=30)
    expect(page.get_by_test_id("strip-armed")).to_have_text("ARMED", timeout=5_000)
    page.get_by_test_id("takeoff-altitude").fill("2.5")
    text = send_command(page, "takeoff", confirm=True)
    assert text == "Take off: accepted.", text
    deadline = time.monotonic() + 25
    alt = None
    while time.monotonic() < deadline:
        alt = number_in(page.get_by_test_id("strip-alt").inner_text())
        if alt is not None and alt > 1.5:
            break
        page.wait_for_timeout(250)
    assert alt is not None and alt > 1.5, f"altitude stayed at {alt}"
    expect(page.get_by_test_id("detection-badge")).to_contain_text("H LOCKED", timeout=15_000)
    expect(page.get_by_test_id("corner-caption")).to_contain_text("corners matched")
    screenshot(page, "dashboard-take-off")
    assert page.evaluate("window.visland.store.thresholdImage") is None
    page.get_by_test_id("toggle-threshold").check()
    page.wait_for_function("window.visland.store.thresholdImage !== null", timeout=10_000)
    # down again for the next tests
    send_command(page, "land", confirm=True)
    expect(page.get_by_test_id("strip-armed")).to_have_text("DISARMED", timeout=60_000)
    assert not page.errors, page.errors


def test_refusal_reasons_and_link_lost(page, tmp_path: Path) -> None:
    """A stand-in far from ready refuses to arm with its PreArm reasons, verbatim; the
    strip says it is not ready; then it dies and the page alerts that the link is lost."""
    if not DIST.exists():
        pytest.fail("the dashboard is not built", pytrace=False)
    station = start_station(tmp_path, ready_after=5.0)
    try:
        open_dashboard(page, station)
        expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=20_000)
        ready = page.get_by_test_id("strip-ready")
        expect(ready).to_contain_text("not ready to arm in", timeout=10_000)
        # the EKF in words, never raw hex flags
        assert "0x" not in page.get_by_test_id("strip-nav").inner_text()
        text = send_command(page, "arm", confirm=True)
        assert text == "Arm: refused by the vehicle (FAILED).", text
        reasons = page.get_by_test_id("command-reasons").locator("li")
        expect(reasons.first).to_be_visible()
        shown = reasons.all_inner_texts()
        assert shown and all(r.startswith(("PreArm:", "Arm:")) for r in shown), shown
        sent = {s["text"] for s in station.get("/api/telemetry")[1]["statustexts"]}
        assert set(shown) <= sent, (shown, sent)
        expect(ready).to_contain_text(shown[-1])  # the vehicle's own words

        station.stand_in.stop()
        expect(page.get_by_test_id("strip-link")).to_contain_text("LOST", timeout=15_000)
        alert = page.get_by_test_id("alert").filter(has_text="Vehicle link lost")
        expect(alert).to_be_visible()
        page.wait_for_function("window.visland.alarm.sounding && window.visland.alarm.beeps > 0")
        screenshot(page, "dashboard-link-lost")
        text = send_command(page, "rtl", confirm=False)
        assert text.startswith("RTL: link down:"), text
        assert not page.errors, page.errors
    finally:
        stop_station(station)
