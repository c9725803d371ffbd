"""A study's inputs as one value that Dask sends to its workers, so that a study runs on
workers that cannot see the client's files (Kubernetes pods, HPC job slots, cloud
workers): the base workflow, the files it reads (link specs, their geometry, driver
tables) and the reduced links the client built, keyed by their content.

The client registers the bundle with the scheduler as a worker plugin
(:class:`BundlePlugin`), which Dask hands to every worker, including workers that join or
restart later; each unpacks it once into a folder of its own under the system's temporary
folder, named by the bundle's key, and runs its cases from there
(:func:`pipeline.study.engine.run_bundled_case`). The relative layout of the
inputs is kept (a workflow's ``../meshes/x.yaml`` still resolves), and the reduced links
are the client's artifacts byte for byte (their input hashes match: they are not rebuilt),
so a case gives the same numbers as on the client's disk.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

try:  # studies need distributed; the bundle itself does not
    from distributed import WorkerPlugin
except ImportError:  # pragma: no cover - the study extra is missing
    WorkerPlugin = object

__all__ = ["Bundle", "BundlePlugin", "bundle_folder", "study_bundle", "unpack"]

#: where workers unpack bundles (under the system's temporary folder)
FOLDER = "flexmech-bundles"


@dataclass(frozen=True)
class Bundle:
    """key : SHA-256 of the contents.  workflow : the base workflow's path in the bundle.
    files : {path in the bundle: bytes}; inputs under ``project/``, reduced links under
    ``links/`` (the cache folder's layout)."""

    key: str
    workflow: str
    files: dict

    @property
    def size(self) -> int:
        """Bytes of content."""
        return sum(len(b) for b in self.files.values())


def study_bundle(wf, inputs, artifacts, cache: Path) -> Bundle:
    """The bundle of the base workflow ``wf`` (its file), the files it reads (``inputs``,
    paths) and the reduced-link artifact folders ``artifacts`` inside ``cache``."""
    sources = [Path(wf.path).resolve(), *(Path(p).resolve() for p in inputs)]
    root = Path(os.path.commonpath([p.parent for p in sources]))
    files = {f"project/{p.relative_to(root).as_posix()}": p.read_bytes() for p in sources}
    for folder in sorted(set(artifacts)):
        for f in sorted(Path(cache, folder).rglob("*")):
            if f.is_file() and not f.name.startswith("."):
                files[f"links/{f.relative_to(cache).as_posix()}"] = f.read_bytes()
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(name.encode() + b"\0")
        h.update(hashlib.sha256(files[name]).digest())
    workflow = f"project/{sources[0].relative_to(root).as_posix()}"
    return Bundle(h.hexdigest(), workflow, files)


def bundle_folder(key: str) -> Path:
    """The folder a bundle of that key is unpacked into on this machine."""
    return Path(tempfile.gettempdir()) / FOLDER / key


def unpack(bundle: Bundle) -> Path:
    """The folder holding ``bundle``'s files on this machine (written once; concurrent
    workers of one machine share it)."""
    done = bundle_folder(bundle.key)
    top = done.parent
    if (done / ".complete").is_file():
        return done
    top.mkdir(parents=True, exist_ok=True)
    _prune(top)
    tmp = Path(tempfile.mkdtemp(prefix=f"{bundle.key[:16]}.", dir=top))
    try:
        for name, data in bundle.files.items():
            path = tmp / name
            if ".." in Path(name).parts or Path(name).is_absolute():
                raise ValueError(f"bundle path {name!r} leaves the bundle")
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        (tmp / ".complete").write_text(bundle.key)
        try:
            os.replace(tmp, done)
        except OSError:  # another worker unpacked it first
            if not (done / ".complete").is_file():
                raise
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return done


#: a bundle unpacked longer ago than this (s) is removed when another is unpacked
KEEP_SECONDS = 7 * 24 * 3600.0


def _prune(top: Path) -> None:
    """Remove the bundles of studies long finished (a machine's temporary folder would
    otherwise collect every study's files)."""
    import time

    for old in top.glob("*/.complete"):
        try:
            if time.time() - old.stat().st_mtime > KEEP_SECONDS:
                shutil.rmtree(old.parent, ignore_errors=True)
        except OSError:
            pass


class BundlePlugin(WorkerPlugin):
    """A Dask worker plugin that unpacks a :class:`Bundle` on every worker it reaches
    (``Client.register_plugin``). A worker that cannot unpack it keeps running; its cases
    then end with the reason (:func:`pipeline.study.engine.run_bundled_case`)."""

    def __init__(self, bundle: Bundle):
        self.bundle = bundle
        self.name = f"flexmech-bundle-{bundle.key[:16]}"

    def setup(self, worker=None) -> None:
        import logging

        try:
            unpack(self.bundle)
        except (OSError, ValueError) as exc:
            logging.getLogger(__name__).error("study files not unpacked: %s", exc)

    def teardown(self, worker=None) -> None:
        pass
