"""A sweep on a Dask cluster (``fpk-vibro run --scheduler ADDRESS``): the connection.

:func:`client` connects with every step bounded (at most
:data:`CONNECT_TIMEOUT`, or ``distributed.comm.timeouts.connect`` if shorter)
and reports a failure in one line that names the address and what happened:

* nothing listens there (refused), the host is unknown or unreachable;
* something accepts but does not greet like a Dask scheduler within the time
  (a scheduler sends its handshake at once);
* something answers that does not speak Dask's protocol (an HTTP server, …):
  the length of its first message is checked before anything is read, so a
  stray "HTTP/1.1" is not taken for a 3 EiB message.

The check reads the greeting on a raw socket, then the real client connects.
"""
from __future__ import annotations

import contextlib
import logging
import socket
import struct
import time
from typing import Any, Iterator

from .._checks import InputError

__all__ = ["client", "CONNECT_TIMEOUT", "quiet"]

#: Longest wait (seconds) for each of: the TCP connection, the scheduler's
#: greeting, the client's own connection.
CONNECT_TIMEOUT = 10.0
#: A Dask handshake is about a hundred bytes; a first message longer than this is
#: not Dask's.
_MAX_GREETING = 1 << 20


def _fail(address: str, what: str) -> InputError:
    return InputError(f"--scheduler {address}: {what}", name="--scheduler")


def _timeout() -> float:
    import dask
    from dask.utils import parse_timedelta
    try:
        t = parse_timedelta(dask.config.get("distributed.comm.timeouts.connect"), "seconds")
    except (KeyError, TypeError, ValueError):
        t = CONNECT_TIMEOUT
    return max(0.5, min(float(t), CONNECT_TIMEOUT))


def _recv(sock: socket.socket, n: int, deadline: float) -> bytes:
    buf = b""
    while len(buf) < n:
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        chunk = sock.recv(n - len(buf))
        if not chunk:
            raise EOFError
        buf += chunk
    return buf


def _probe(address: str, host: str, port: int, greeting: bool, timeout: float) -> None:
    """Connect to ``host:port`` and (``greeting``) read a Dask scheduler's handshake."""
    try:
        sock = socket.create_connection((host, port), timeout=timeout)
    except socket.timeout:
        raise _fail(address, f"no connection within {timeout:g} s (host down or "
                             "firewalled?)") from None
    except ConnectionRefusedError:
        raise _fail(address, "connection refused: no scheduler listens there") from None
    except socket.gaierror as exc:
        raise _fail(address, f"unknown host {host!r} ({exc.strerror})") from None
    except OSError as exc:
        raise _fail(address, f"cannot connect ({exc.strerror or exc})") from None
    with sock:
        if not greeting:
            return
        deadline = time.monotonic() + timeout
        try:
            head = _recv(sock, 8, deadline)
            (size,) = struct.unpack("<Q", head)
            if not 0 < size <= _MAX_GREETING:
                raise _fail(address, f"the service there is not a Dask scheduler (it "
                                     f"answered {head!r})")
            payload = _recv(sock, size, deadline)
        except socket.timeout:
            raise _fail(address, f"connected, but no Dask scheduler answered within "
                                 f"{timeout:g} s (not a Dask scheduler, or a stuck one)") from None
        except EOFError:
            raise _fail(address, "connected, but the service closed the connection "
                                 "without a greeting: not a Dask scheduler") from None
        except OSError as exc:
            raise _fail(address, f"connection lost during the greeting "
                                 f"({exc.strerror or exc})") from None
    try:
        from distributed.protocol.utils import unpack_frames
        unpack_frames(payload, partial=True)
    except Exception:
        raise _fail(address, "the service there is not a Dask scheduler (its greeting "
                             "is not Dask's)") from None


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """Silence distributed's loggers (a lost scheduler logs tracebacks); the run
    reports every failure itself, in one line."""
    names = ["distributed"] + [n for n in logging.root.manager.loggerDict
                               if n.startswith("distributed.")]
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def client(address: str) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``; :class:`InputError`
    (one line: the address and what happened) if there is none, within about
    3 × :data:`CONNECT_TIMEOUT` at worst."""
    from distributed import Client
    from distributed.comm import parse_address, parse_host_port
    timeout = _timeout()
    try:
        scheme, loc = parse_address(address)
        if scheme in ("tcp", "tls"):
            host, port = parse_host_port(loc, default_port=8786)
    except (ValueError, TypeError) as exc:
        raise _fail(address, f"not a scheduler address ({exc})") from None
    if scheme in ("tcp", "tls"):
        _probe(address, host, port, greeting=scheme == "tcp", timeout=timeout)
    try:
        with quiet():
            return Client(address, timeout=timeout, set_as_default=False)
    except Exception as exc:
        raise _fail(address, "cannot connect: " + " ".join(
            f"{type(exc).__name__}: {exc}".split())[:300]) from None
