"""The CPU and memory limits of this process's control groups (Linux cgroup v1 and v2).

A container or a systemd unit limits a process through its control groups, not through what
``os.sched_getaffinity`` or ``/proc/meminfo`` report: ``docker run --cpus 2`` on a 64-core
machine leaves the affinity at 64 cores, and ``--memory 4g`` leaves ``MemAvailable`` at the
machine's.  ``batch --jobs auto`` and the memory checks read both, the smaller winning.

Where the groups are is read as the kernel gives it (``proc(5)``): ``/proc/self/cgroup`` names
the process's group in each hierarchy (``0::/user.slice/...`` for v2, ``4:memory:/docker/...``
for v1) and ``/proc/self/mountinfo`` where each hierarchy is mounted and which group its mount
point shows (a container's own group shows at ``/sys/fs/cgroup`` under the host's path).  A
limit set on a parent group binds its children too, so the group and each of its ancestors up
to the mount point is read, and the tightest limit counts.  Where the group's own folder is not
under the mount (a v1 container without a cgroup namespace names the host's path), the mount
point, the container's group, is read.

- **CPU**: v2 ``cpu.max`` (``"<quota> <period>"`` or ``"max <period>"``), v1
  ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us`` (quota ``-1``: none): quota / period cores.
- **Memory**: the limit (v2 ``memory.max``, v1 ``memory.limit_in_bytes``) less the group's
  working set, its usage (``memory.current``, ``memory.usage_in_bytes``) without the inactive
  file cache (``inactive_file``, v1 ``total_inactive_file`` in ``memory.stat``), which the
  kernel reclaims before it fails an allocation; kubelet and ``docker stats`` count it so.

Anything unreadable or malformed says nothing (``None``): then no limit is applied.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

__all__ = ["cpu_limit", "memory_room"]

PROC = Path("/proc/self")
"""Where the kernel describes this process (tests give a folder of their own)."""


@dataclass(frozen=True)
class _Mount:
    """One mounted cgroup hierarchy: its mount point, the group shown there, its controllers."""

    point: Path
    root: PurePosixPath
    controllers: frozenset[str]
    """The v1 controllers it holds (``cpu``, ``cpuacct``, ``memory``...); empty for v2."""


def _unescape(field: str) -> str:
    """A mountinfo path field, whose space, tab, newline and backslash are octal escapes."""
    return re.sub(r"\\([0-7]{3})", lambda match: chr(int(match.group(1), 8)), field)


def _mounts(proc: Path) -> list[_Mount]:
    """The cgroup hierarchies mounted in this process's mount namespace."""
    mounts = []
    for line in (proc / "mountinfo").read_text().splitlines():
        fields = line.split(" ")
        if "-" not in fields[6:]:
            continue
        separator = fields.index("-", 6)
        kind, options = fields[separator + 1], fields[separator + 3 : separator + 4]
        if kind not in ("cgroup", "cgroup2") or len(fields) < 5:
            continue
        controllers = frozenset(options[0].split(",")) if kind == "cgroup" and options else None
        mounts.append(
            _Mount(
                point=Path(_unescape(fields[4])),
                root=PurePosixPath(_unescape(fields[3])),
                controllers=controllers or frozenset(),
            )
        )
    return mounts


def _groups(proc: Path) -> dict[frozenset[str], PurePosixPath]:
    """The process's group in each hierarchy, keyed by its controllers (v2: the empty set)."""
    groups = {}
    for line in (proc / "cgroup").read_text().splitlines():
        parts = line.split(":", 2)
        if len(parts) == 3:
            names = frozenset(name for name in parts[1].split(",") if name)
            groups[names] = PurePosixPath(parts[2])
    return groups


def _folders(controller: str, proc: Path) -> Iterator[Path]:
    """The folders of this process's group and of its ancestors, for ``controller``."""
    try:
        mounts, groups = _mounts(proc), _groups(proc)
    except (OSError, UnicodeDecodeError, ValueError, IndexError):
        return
    for mount in mounts:
        if mount.controllers and controller not in mount.controllers:
            continue
        if mount.controllers:
            group = groups.get(
                next((names for names in groups if controller in names), frozenset()), None
            )
        else:
            group = groups.get(frozenset())
        if group is None:
            continue
        try:
            relative = group.relative_to(mount.root)
        except ValueError:
            relative = PurePosixPath()
        if ".." in relative.parts:  # a group outside the cgroup namespace (proc(5)): not here
            relative = PurePosixPath()
        folder = mount.point.joinpath(*relative.parts[relative.is_absolute() :])
        while True:
            if folder.is_dir():
                yield folder
            if folder == mount.point or folder.parent == folder:
                break
            folder = folder.parent


def _read(folder: Path, name: str) -> str | None:
    try:
        return (folder / name).read_text().strip()
    except (OSError, UnicodeDecodeError):
        return None


def _whole(text: str | None) -> int | None:
    if text is None or not re.fullmatch(r"-?[0-9]+", text):
        return None
    return int(text)


def _cores(folder: Path) -> float | None:
    """The cores a folder's quota gives (v2 ``cpu.max``, else v1's pair), ``None`` for none."""
    limit = _read(folder, "cpu.max")
    if limit is not None:
        quota, _, period = limit.partition(" ")
        quota_us, period_us = _whole(quota), _whole(period)
    else:
        quota_us = _whole(_read(folder, "cpu.cfs_quota_us"))
        period_us = _whole(_read(folder, "cpu.cfs_period_us"))
    if quota_us is None or period_us is None or quota_us <= 0 or period_us <= 0:
        return None
    return quota_us / period_us


def cpu_limit(proc: Path = PROC) -> float | None:
    """The cores this process's CPU quota allows (``1.5`` for ``--cpus 1.5``), ``None`` for none."""
    limits = [cores for folder in _folders("cpu", proc) if (cores := _cores(folder)) is not None]
    return min(limits, default=None)


def _inactive_file(folder: Path) -> int:
    """The bytes of the group's inactive file cache, which its usage counts.

    v1's ``total_inactive_file`` (the hierarchy's, as ``memory.usage_in_bytes``), else
    ``inactive_file`` (v2's is the hierarchy's; v1's, listed first, the group's own).
    """
    stat: dict[str, str] = {}
    for line in (_read(folder, "memory.stat") or "").splitlines():
        key, _, value = line.partition(" ")
        stat[key] = value
    for key in ("total_inactive_file", "inactive_file"):
        if (number := _whole(stat.get(key))) is not None:
            return max(number, 0)
    return 0


def _room(folder: Path) -> int | None:
    """Bytes a folder's limit leaves above its working set, ``None`` where it sets none."""
    limit = _whole(_read(folder, "memory.max") or _read(folder, "memory.limit_in_bytes"))
    usage = _whole(_read(folder, "memory.current") or _read(folder, "memory.usage_in_bytes"))
    if limit is None or usage is None:
        return None
    return max(limit - max(usage - _inactive_file(folder), 0), 0)


def memory_room(proc: Path = PROC) -> int | None:
    """Bytes this process's memory limits leave it, ``None`` where no group sets one."""
    rooms = [room for folder in _folders("memory", proc) if (room := _room(folder)) is not None]
    return min(rooms, default=None)
