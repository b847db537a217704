"""Network namespaces standing in for hosts, for multi-host deployment tests.

``NetnsLab(n)`` creates ``n`` "host" namespaces plus one "switch" namespace that
holds a Linux bridge; each host gets an ``eth0`` veth whose peer is plugged into
that bridge, an address ``<subnet>.<i+1>/24`` and a loopback. Nothing is created
in, or routed to, the namespace the tests run in: the private /24 exists only
inside the lab's namespaces, so its traffic cannot leave the machine.

    with NetnsLab(3) as lab:
        lab.hosts            # ["wm<pid>h0", "wm<pid>h1", "wm<pid>h2"]
        lab.addr(1)          # "10.213.77.2"
        lab.cmd(1, "python", "x.py")   # ["ip", "netns", "exec", "wm<pid>h1", "python", "x.py"]

Teardown stops (SIGTERM, then SIGKILL, by PID) every process still running in
the lab's namespaces, then deletes the namespaces; the veths and the bridge go
with them. ``netns_unavailable()`` says why a lab cannot be built here (not
root, no ``ip``, ``ip netns add`` refused, no veth/bridge support) or ``None``.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from types import TracebackType

DEFAULT_SUBNET = "10.213.77"


def _ip(*args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=20, check=check)


def netns_unavailable() -> str | None:
    """Why network namespaces cannot be used here, or None when they can."""
    if shutil.which("ip") is None:
        return "the `ip` command (iproute2) is not installed"
    if os.geteuid() != 0:
        return "creating network namespaces needs root"
    probe = f"wmprobe{os.getpid()}"
    add = _ip("netns", "add", probe, check=False)
    if add.returncode != 0:
        return f"`ip netns add` is not permitted here: {add.stderr.strip()}"
    try:
        veth = _ip("-n", probe, "link", "add", "p0", "type", "veth", "peer", "name", "p1", check=False)
        if veth.returncode != 0:
            return f"cannot create veth pairs in a namespace: {veth.stderr.strip()}"
        br = _ip("-n", probe, "link", "add", "br0", "type", "bridge", check=False)
        if br.returncode != 0:
            return f"cannot create a bridge in a namespace: {br.stderr.strip()}"
    finally:
        _ip("netns", "del", probe, check=False)
    return None


class NetnsLab:
    """``n`` host namespaces on one bridged /24 (see module doc)."""

    def __init__(self, n: int, subnet: str = DEFAULT_SUBNET, prefix: str | None = None) -> None:
        if not 1 <= n <= 250:
            raise ValueError("a lab has 1..250 hosts")
        self.n = n
        self.subnet = subnet
        self.prefix = prefix or f"wm{os.getpid() % 100000}"
        self.switch = f"{self.prefix}sw"
        self.hosts = [f"{self.prefix}h{i}" for i in range(n)]
        self._created: list[str] = []

    # -- addressing ------------------------------------------------------
    def addr(self, i: int) -> str:
        return f"{self.subnet}.{i + 1}"

    def cmd(self, i: int, *argv: str) -> list[str]:
        """argv that runs ``argv`` inside host ``i``'s namespace."""
        return ["ip", "netns", "exec", self.hosts[i], *argv]

    def run(self, i: int, *argv: str, timeout: float = 20) -> subprocess.CompletedProcess[str]:
        return subprocess.run(self.cmd(i, *argv), capture_output=True, text=True, timeout=timeout)

    # -- lifecycle -------------------------------------------------------
    def up(self) -> NetnsLab:
        try:
            self._add_ns(self.switch)
            _ip("-n", self.switch, "link", "add", "br0", "type", "bridge")
            _ip("-n", self.switch, "link", "set", "br0", "up")
            for i, host in enumerate(self.hosts):
                self._add_ns(host)
                _ip("-n", host, "link", "set", "lo", "up")
                _ip("-n", host, "link", "add", "eth0", "type", "veth", "peer", "name", f"port{i}", "netns", self.switch)
                _ip("-n", self.switch, "link", "set", f"port{i}", "master", "br0")
                _ip("-n", self.switch, "link", "set", f"port{i}", "up")
                _ip("-n", host, "addr", "add", f"{self.addr(i)}/24", "dev", "eth0")
                _ip("-n", host, "link", "set", "eth0", "up")
            self._wait_reachable()
        except BaseException:
            self.down()
            raise
        return self

    def _add_ns(self, name: str) -> None:
        _ip("netns", "del", name, check=False)  # a leftover of a killed run with the same pid
        _ip("netns", "add", name)
        self._created.append(name)

    def _wait_reachable(self, timeout: float = 10.0) -> None:
        """Until every bridge port forwards and every eth0 is up (no ping needed)."""
        deadline = time.monotonic() + timeout
        for i, host in enumerate(self.hosts):
            while not (
                "state forwarding" in _ip("-n", self.switch, "-d", "link", "show", f"port{i}").stdout
                and ",UP," in _ip("-n", host, "link", "show", "eth0").stdout.replace("<", ",").replace(">", ",")
            ):
                if time.monotonic() > deadline:
                    raise RuntimeError(f"bridge port of {host} not forwarding after {timeout} s")
                time.sleep(0.05)

    def pids(self) -> list[int]:
        out: list[int] = []
        for name in self._created:
            res = _ip("netns", "pids", name, check=False)
            out += [int(p) for p in res.stdout.split() if p.isdigit()]
        return out

    def down(self) -> None:
        """Stop the processes left in the lab (by PID), then delete its namespaces."""
        pids = self.pids()
        for pid in pids:
            try:
                os.kill(pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + 5
        while pids and time.monotonic() < deadline:
            pids = [p for p in pids if _alive(p)]
            time.sleep(0.05)
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for name in reversed(self._created):
            _ip("netns", "del", name, check=False)
        self._created.clear()

    def __enter__(self) -> NetnsLab:
        return self.up()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.down()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie child of ours counts as gone
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False
