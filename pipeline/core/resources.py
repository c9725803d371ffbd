"""What the machine can give a job, from the operating system: memory available now, and
the address space this process maps (now and at its peak)."""

from __future__ import annotations

import os
import resource

__all__ = ["address_space", "available_memory", "peak_address_space"]


def _kib_field(path: str, key: str) -> int | None:
    """Bytes of the ``key:`` line (in kB) of a /proc status file, or None where there is
    none (not Linux)."""
    try:
        with open(path) as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation now (Linux ``MemAvailable``; else the
    free physical pages), or None where the system does not say."""
    found = _kib_field("/proc/meminfo", "MemAvailable")
    if found is not None:
        return found
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def peak_address_space() -> int:
    """Bytes of address space this process has mapped at its peak (``VmPeak``); 0 where
    the system does not say."""
    return _kib_field("/proc/self/status", "VmPeak") or 0


def address_space() -> int:
    """Bytes of address space this process maps now; 0 where the system does not say."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[0]) * resource.getpagesize()
    except OSError:
        return 0
