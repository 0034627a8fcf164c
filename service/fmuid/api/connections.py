"""Connection limits in front of the app: open files, concurrent connections, slow request heads.

uvicorn bounds idle keep-alive connections (``timeout_keep_alive``) but not a connection that
sends its request head slowly or never (slowloris): each such connection holds a file
descriptor for good, and once the process runs out of them nothing is accepted, health
included. So the service

- raises its soft limit of open files to the hard one (:func:`raise_open_files`);
- closes a connection whose request head is not complete :attr:`Settings.header_timeout_s`
  after it opened or after its last response (:class:`HeadTimeoutH11`);
- answers 503 to requests beyond ``limit_concurrency`` connections (uvicorn), a number kept
  below the open-file limit (:func:`connection_limit`) so that a flood gets 503 instead of
  starving the store, the jobs' logs and the checking processes of file descriptors.
"""

from __future__ import annotations

import asyncio
import logging
import resource
from typing import Any

from uvicorn.protocols.http.h11_impl import H11Protocol

logger = logging.getLogger(__name__)

RESERVED_FILES = 256
"""Open files kept for the service's own use (store, logs, pipes) beyond its connections."""


def raise_open_files() -> int:
    """Raise the soft limit of open files to the hard limit where allowed; return the soft one."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard == resource.RLIM_INFINITY or hard > soft:
        target = hard if hard != resource.RLIM_INFINITY else max(soft, 1 << 20)
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
            soft = target
        except (ValueError, OSError) as exc:
            logger.warning("cannot raise the open-file limit from %d to %d: %s", soft, hard, exc)
    return soft


def connection_limit(wanted: int, open_files: int) -> int:
    """Return ``wanted`` connections, or fewer when the open-file limit cannot hold them."""
    room = max(open_files - RESERVED_FILES, 16)
    if wanted > room:
        logger.warning(
            "FMUID_MAX_CONNECTIONS=%d does not fit in %d open files: %d connections at most",
            wanted,
            open_files,
            room,
        )
        return room
    return wanted


class HeadTimeoutH11(H11Protocol):
    """uvicorn's h11 protocol that closes a connection whose request head is late.

    The deadline (class attribute :attr:`head_timeout_s`, set by :func:`protocol`) runs from
    the connection's start and from the end of each response, and stops when a request head
    has arrived; the body of an upload is not under it.
    """

    head_timeout_s = 10.0

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        """Start the deadline of the first request head."""
        super().connection_made(transport)
        self._head_timer: asyncio.TimerHandle | None = None
        self._arm()

    def handle_events(self) -> None:
        """Stop the deadline once a request head has arrived (a new request cycle)."""
        cycle = self.cycle
        super().handle_events()
        if self.cycle is not cycle:
            self._disarm()

    def on_response_complete(self) -> None:
        """Start the deadline of the next request head on a kept-alive connection."""
        super().on_response_complete()
        self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        """Forget the deadline."""
        self._disarm()
        super().connection_lost(exc)

    def _arm(self) -> None:
        self._disarm()
        self._head_timer = self.loop.call_later(self.head_timeout_s, self._late_head)

    def _disarm(self) -> None:
        if self._head_timer is not None:
            self._head_timer.cancel()
            self._head_timer = None

    def _late_head(self) -> None:
        self._head_timer = None
        if not self.transport.is_closing():
            self.transport.close()


def protocol(head_timeout_s: float) -> type[Any]:
    """Return :class:`HeadTimeoutH11` with the deadline ``head_timeout_s`` [s]."""
    return type("HeadTimeoutH11", (HeadTimeoutH11,), {"head_timeout_s": head_timeout_s})
