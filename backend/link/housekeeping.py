"""The link's housekeeper thread: our HEARTBEAT at 1 Hz, heartbeat loss, telemetry
stream requests, link-quality figures, and flushing the tlog."""

from __future__ import annotations

import contextlib
import logging
import time
from collections import deque

from backend.link import streams
from backend.link.connection import SendError
from backend.link.core import _TICK_S, LinkCore
from backend.link.state import LinkState

log = logging.getLogger("backend.link.vehicle_link")


class LinkHousekeeping(LinkCore):
    """The housekeeping thread of :class:`~backend.link.VehicleLink`."""

    # ------------------------------------------------------------------ housekeeping thread
    def _housekeeping_loop(self) -> None:
        next_flush = 0.0
        rates: deque[tuple[float, int]] = deque(maxlen=32)
        while not self._stop.is_set():
            self._wake.wait(_TICK_S)
            self._wake.clear()
            if self._stop.is_set():
                break
            now = time.monotonic()
            try:
                if now >= self._hb_sent_at + 1.0:  # (the reader sends one on connecting)
                    self._send_heartbeat()
                self._check_heartbeat(now)
                self._manage_streams(now)
                self._update_quality(now, rates)
                if now >= next_flush and self._tlog is not None:
                    next_flush = now + 1.0
                    self._tlog.flush()
            except Exception:
                self._handler_errors += 1
                log.exception("vehicle link housekeeping failed")

    def _check_heartbeat(self, now: float) -> None:
        last = self._last_hb
        if self._state == LinkState.UP and last is not None and now - last > self._hb_timeout:
            self._set_state(LinkState.LOST, f"no heartbeat for {self._hb_timeout:g} s")

    def _manage_streams(self, now: float) -> None:
        target = self._target
        if self._state != LinkState.UP or target is None:
            return
        action = self._streams.due(now, self._telemetry.attitude_rx_monotonic)
        if action == "intervals":
            messages = streams.interval_messages(target, self._stream_rates)
        elif action == "data_streams":
            messages = streams.data_stream_messages(target)
        else:
            return
        for msg in messages:
            with contextlib.suppress(SendError):  # the reader notices a dead transport
                self._send(msg)

    def _update_quality(self, now: float, rates: deque[tuple[float, int]]) -> None:
        transport = self._transport
        assert transport is not None
        rates.append((now, self._rx_count))
        while len(rates) > 2 and now - rates[0][0] > 2.0:
            rates.popleft()
        t_old, n_old = rates[0]
        per_s = (self._rx_count - n_old) / (now - t_old) if now > t_old else 0.0
        self._apply(
            {
                "msgs_per_s": round(per_s, 2),
                "crc_errors": transport.receive_errors,
                "packets_lost_pct": round(transport.packets_lost_pct, 2),
                "handler_errors": self._handler_errors,
                "reconnects": max(0, transport.opened - 1),
            }
        )
