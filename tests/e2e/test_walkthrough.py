"""The README's walkthrough, as a new operator does it: start the station the way
`make run` does (the built-in stand-in, no vehicle named), open the URL it prints, and
land on the pad by precision landing without leaving the dashboard, at 1280x720.

The only difference from `make run`: the stand-in gets ready faster (--sim-ready-after)
and the ports are free ones, so the test takes minutes, not more.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.e2e.support import (
    DIST,
    NO_CHROMIUM,
    START_TIMEOUT_S,
    Proc,
    confirm,
    expect,
    number_in,
    screenshot,
)
from tests.serve import free_port, serve_command

pytestmark = [pytest.mark.e2e, pytest.mark.slow, NO_CHROMIUM]


def test_a_new_operator_lands_the_stand_in_by_precision_landing(browser, tmp_path):
    if not DIST.exists():
        pytest.fail("the dashboard is not built: run make install", pytrace=False)
    port, viser_port = free_port(), free_port()
    server = Proc(
        "make-run",
        serve_command(port, viser_port, tmp_path / "data", "--sim-ready-after", "0.3"),
        tmp_path,
    )
    context = browser.new_context(viewport={"width": 1280, "height": 720})
    try:
        server.wait_for_line(r"dashboard  http://\S+", START_TIMEOUT_S)
        url = re.search(r"dashboard  (http://\S+)", server.output()).group(1)
        # printed only to a terminal; into a pipe the banner says where it is kept
        kept = re.search(r"token +.*kept in (\S+?)\)?$", server.output(), re.M).group(1)
        token = Path(kept).read_text().strip()
        # the address is printed as the server starts: it answers a moment later
        server.wait_for_line(r"Uvicorn running on|Application startup complete", START_TIMEOUT_S)
        page = context.new_page()
        page.set_default_timeout(15_000)
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        # README step 1: open the printed address, type the token in
        page.goto(url)
        page.get_by_test_id("token-input").fill(token)
        page.get_by_test_id("token-save").click()
        expect(page.get_by_test_id("token-state")).to_have_text("token set", timeout=20_000)
        assert token not in page.url
        expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=30_000)
        # step 2: set up precision landing (the landing panel says it is off)
        expect(page.get_by_test_id("plnd-state")).to_contain_text("off on the vehicle")
        page.get_by_test_id("precland-setup").click()
        confirm(page, expect_text="Then the autopilot reboots")
        expect(page.get_by_test_id("plnd-state")).to_contain_text("is set up", timeout=30_000)
        # step 3: wait until the strip says the vehicle is ready to arm, with a position
        expect(page.get_by_test_id("strip-link")).to_have_text("UP", timeout=30_000)
        expect(page.get_by_test_id("strip-nav")).to_contain_text("position OK", timeout=60_000)
        expect(page.get_by_test_id("strip-ready")).to_contain_text("ready to arm", timeout=60_000)
        # step 4: hover over the pad (arms, takes off, flies over it)
        page.get_by_test_id("hover").click()
        confirm(page, expect_text="takes off to 4 m")
        state = page.get_by_test_id("mission-panel-state")
        expect(state).to_contain_text("hover · hold", timeout=90_000)
        expect(page.get_by_test_id("detection-badge")).to_contain_text("H LOCKED", timeout=30_000)
        screenshot(page, "walkthrough-hover")
        # step 5: land on the pad (ArduCopter precision landing), the hover stops first
        page.get_by_test_id("abort").click()
        expect(page.get_by_test_id("abort-outcome")).to_contain_text("position hold")
        page.get_by_test_id("mission-land").click()
        confirm(page, expect_text="ArduCopter's precision landing steers")
        expect(page.get_by_test_id("mission-outcome")).to_have_text("Landing started (plnd).")
        expect(state).to_contain_text("land (plnd) · descend", timeout=90_000)
        screenshot(page, "walkthrough-descend")
        expect(state).to_contain_text("landed", timeout=180_000)
        first = page.get_by_test_id("mission-history").locator("tbody tr").first
        expect(first).to_contain_text("land (plnd)")
        expect(first).to_contain_text("landed")
        cm = number_in(first.inner_text().split("landed", 1)[1])
        assert cm is not None and cm < 25.0, first.inner_text()
        expect(page.get_by_test_id("strip-armed")).to_have_text("DISARMED", timeout=30_000)
        screenshot(page, "walkthrough-landed")
        assert not errors, errors
    finally:
        context.close()
        server.stop()
