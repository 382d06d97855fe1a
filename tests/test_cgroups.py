"""Control groups' CPU and memory limits (``hybridlog.cgroups``), on kernel files written here.

Each case writes a ``/proc/self`` (``cgroup``, ``mountinfo``) and the cgroup folders it names,
as the kernel lays them out for a container or a systemd unit.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog import cgroups, environment, memory

GB = 1 << 30


def _mountinfo_line(point: Path, root: str, kind: str, options: str) -> str:
    escaped = str(point).replace(" ", "\\040")
    return f"30 25 0:26 {root} {escaped} rw,nosuid - {kind} {kind} {options}"


def _write(folder: Path, **files: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name.replace("__", ".")).write_text(text + "\n")


def _proc(tmp_path: Path, cgroup: str, *mounts: str) -> Path:
    proc = tmp_path / "proc"
    proc.mkdir()
    (proc / "cgroup").write_text(cgroup)
    (proc / "mountinfo").write_text(
        "22 1 8:1 / / rw,relatime - ext4 /dev/sda1 rw\n" + "\n".join(mounts) + "\n"
    )
    return proc


def test_a_v2_container_reads_its_own_group_at_the_mount_point(tmp_path: Path) -> None:
    """``docker run --cpus 1.5 --memory 4g`` with a cgroup namespace: ``0::/``."""
    mount = tmp_path / "sys fs cgroup"  # a space, escaped in mountinfo
    _write(
        mount,
        cpu__max="150000 100000",
        memory__max=str(4 * GB),
        memory__current=str(3 * GB),
        memory__stat="anon 1000\ninactive_file 1073741824\nactive_file 5",
    )
    proc = _proc(tmp_path, "0::/\n", _mountinfo_line(mount, "/", "cgroup2", "rw,nsdelegate"))
    assert cgroups.cpu_limit(proc) == 1.5
    # the inactive file cache is reclaimed before an allocation fails: 4 - (3 - 1) GB
    assert cgroups.memory_room(proc) == 2 * GB


def test_a_v2_parent_limit_binds_the_group(tmp_path: Path) -> None:
    """``systemd-run -p CPUQuota=300% -p MemoryMax=...`` on a slice: the tightest counts."""
    mount = tmp_path / "cgroup"
    _write(mount)  # the root group sets nothing
    _write(
        mount / "user.slice",
        cpu__max="200000 100000",
        memory__max=str(8 * GB),
        memory__current=str(7 * GB),
    )
    _write(
        mount / "user.slice" / "run-1.scope",
        cpu__max="max 100000",
        memory__max="max",
        memory__current=str(GB),
    )
    proc = _proc(
        tmp_path,
        "0::/user.slice/run-1.scope\n",
        _mountinfo_line(mount, "/", "cgroup2", "rw"),
    )
    assert cgroups.cpu_limit(proc) == 2.0
    assert cgroups.memory_room(proc) == GB


def test_v1_without_a_namespace_reads_the_mount_point(tmp_path: Path) -> None:
    """v1 names the host's path (``/docker/abc``), which is not under the container's mount."""
    cpu = tmp_path / "cgroup" / "cpu,cpuacct"
    mem = tmp_path / "cgroup" / "memory"
    _write(cpu, cpu__cfs_quota_us="50000", cpu__cfs_period_us="100000")
    _write(
        mem,
        memory__limit_in_bytes=str(2 * GB),
        memory__usage_in_bytes=str(GB),
        memory__stat="cache 5\ntotal_inactive_file 536870912",
    )
    proc = _proc(
        tmp_path,
        "12:memory:/docker/abc\n4:cpu,cpuacct:/docker/abc\n1:name=systemd:/docker/abc\n",
        _mountinfo_line(cpu, "/docker/abc", "cgroup", "rw,cpu,cpuacct"),
        _mountinfo_line(mem, "/docker/abc", "cgroup", "rw,memory"),
    )
    assert cgroups.cpu_limit(proc) == 0.5
    assert cgroups.memory_room(proc) == GB + GB // 2


def test_no_limit_and_unreadable_files_say_nothing(tmp_path: Path) -> None:
    """An unlimited v1 quota (``-1``), ``max``, malformed text or no files: no limit."""
    cpu = tmp_path / "cpu"
    mem = tmp_path / "memory"
    _write(cpu, cpu__cfs_quota_us="-1", cpu__cfs_period_us="100000")
    _write(mem, memory__limit_in_bytes="lots", memory__usage_in_bytes="12")
    proc = _proc(
        tmp_path,
        "3:cpu:/\n4:memory:/\n",
        _mountinfo_line(cpu, "/", "cgroup", "rw,cpu"),
        _mountinfo_line(mem, "/", "cgroup", "rw,memory"),
    )
    assert cgroups.cpu_limit(proc) is None
    assert cgroups.memory_room(proc) is None
    assert cgroups.cpu_limit(tmp_path / "no proc") is None
    assert cgroups.memory_room(tmp_path / "no proc") is None


def test_the_quota_caps_the_cores_and_the_limit_the_memory(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``--jobs auto`` and the memory checks read the groups' limits, rounded up for cores."""
    monkeypatch.setattr(environment, "cpu_limit", lambda: None)
    cores = environment.usable_cores()
    monkeypatch.setattr(environment, "cpu_limit", lambda: 0.5)
    assert environment.usable_cores() == 1
    monkeypatch.setattr(environment, "cpu_limit", lambda: 10_000.0)
    assert environment.usable_cores() == cores
    if cores > 1:
        monkeypatch.setattr(environment, "cpu_limit", lambda: 1.2)
        assert environment.usable_cores() == 2
    monkeypatch.setattr(memory, "memory_room", lambda: 12_345)
    assert memory.available_memory() == 12_345


def test_v1_counts_the_hierarchy_s_inactive_file_cache(tmp_path: Path) -> None:
    """v1 counts the hierarchy's ``total_inactive_file``, not the group's own listed first.

    ``memory.usage_in_bytes`` counts the hierarchy, children included.
    """
    mem = tmp_path / "memory"
    _write(
        mem,
        memory__limit_in_bytes=str(4 * GB),
        memory__usage_in_bytes=str(3 * GB),
        memory__stat=f"cache 5\ninactive_file 20480\ntotal_cache 5\ntotal_inactive_file {GB}",
    )
    proc = _proc(tmp_path, "4:memory:/\n", _mountinfo_line(mem, "/", "cgroup", "rw,memory"))
    assert cgroups.memory_room(proc) == 2 * GB


def test_a_group_outside_the_namespace_reads_no_folder_outside_the_mount(tmp_path: Path) -> None:
    """A group outside the namespace's root, ``/../sibling`` (``proc(5)``): only the mount.

    Never a folder above the mount point.
    """
    mount = tmp_path / "sys" / "fs" / "cgroup"
    _write(mount)
    _write(tmp_path / "sys", cpu__max="100000 100000", memory__max="1", memory__current="0")
    proc = _proc(tmp_path, "0::/../../sibling\n", _mountinfo_line(mount, "/", "cgroup2", "rw"))
    assert cgroups.cpu_limit(proc) is None
    assert cgroups.memory_room(proc) is None


def test_a_hybrid_host_with_cpu_and_cpuacct_apart(tmp_path: Path) -> None:
    """v1 ``cpu`` and ``cpuacct`` mounted apart, ``memory`` whose mount shows a sub-path, a v2
    ``unified`` beside them, mountinfo's optional fields and a ``:`` in a group's name."""
    cpu, acct = tmp_path / "cpu", tmp_path / "cpuacct"
    mem, unified = tmp_path / "memory", tmp_path / "unified"
    _write(cpu / "a:b", cpu__cfs_quota_us="250000", cpu__cfs_period_us="100000")
    _write(acct / "a:b", cpu__cfs_quota_us="50000", cpu__cfs_period_us="100000")  # not cpu's
    _write(mem / "sub", memory__limit_in_bytes=str(GB), memory__usage_in_bytes="0")
    _write(unified / "a:b", cgroup__procs="1")  # no controller enabled in v2: no limit files
    optional = "30 25 0:26 {root} {point} rw shared:1 master:2 - cgroup{v} cgroup {options}"
    proc = _proc(
        tmp_path,
        "2:cpuacct:/a:b\n1:cpu:/a:b\n4:memory:/docker/x/sub\n0::/a:b\n",
        optional.format(root="/", point=cpu, v="", options="rw,cpu"),
        optional.format(root="/", point=acct, v="", options="rw,cpuacct"),
        optional.format(root="/docker/x", point=mem, v="", options="rw,memory"),
        optional.format(root="/", point=unified, v="2", options="rw"),
    )
    assert cgroups.cpu_limit(proc) == 2.5
    assert cgroups.memory_room(proc) == GB
