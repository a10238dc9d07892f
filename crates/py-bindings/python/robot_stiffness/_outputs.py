"""Output files and folders that never lose anything the tool did not write.

Every output is *reserved* before the long computation (the checks run then, and a temporary
file or folder is created, which proves the location is writable) and *committed* at the very
end by renaming; on any error, Ctrl-C or SIGTERM :meth:`Outputs.discard` removes the
temporaries and nothing else.

* A file (``--json``, ``--truth``, ``OUT.csv``) is staged as ``.NAME.tmp-*`` next to it and
  renamed over it on commit. It must not be a folder, nor one of the input files.
* A folder (``--report DIR``, ``demo --out DIR``):

  - missing: staged as ``.DIR.tmp-*`` next to it and renamed to DIR on commit;
  - empty: filled on commit;
  - not empty: refused unless ``force``; then only the files listed in the tool's manifest
    ``DIR/.robot-stiffness-manifest.json`` (written by an earlier run, with a SHA-256 per file)
    and still unchanged are replaced or removed. Any other file — the user's data, notes,
    subfolders — is left byte-identical; a name the tool needs that is taken by such a file is
    refused before anything is written.

Nothing here calls ``shutil.rmtree`` on anything but the tool's own temporary folders.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Dict, Iterable, List, Optional, Sequence, Set, Tuple, Union

from ._errors import OutputPathError
from ._interrupt import signals_deferred

__all__ = ["Outputs", "StagedFile", "StagedDirectory", "MANIFEST", "TMP_MARK"]

PathLike = Union[str, "os.PathLike[str]"]

#: The manifest of the files the tool wrote into an output folder.
MANIFEST = ".robot-stiffness-manifest.json"
#: Every temporary name contains this mark (``.NAME.tmp-XXXXXXXX``).
TMP_MARK = ".tmp-"
_MANIFEST_TAG = "robot-stiffness output manifest"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _umask()


def _reason(e: OSError) -> str:
    """A short human reason for an OS error (no temporary names)."""
    if e.errno == errno.EROFS:
        return "read-only file system"
    if e.errno in (errno.EACCES, errno.EPERM):
        return "permission denied"
    if e.errno == errno.ENOENT:  # the folder exists (checked before) but refuses new files
        return "cannot create files in that folder"
    if e.errno == errno.ENOSPC:
        return "no space left on device"
    if e.errno == errno.ENOTDIR:
        return "a part of the path is not a folder"
    return e.strerror or type(e).__name__


def _label(path: Path, flag: Optional[str]) -> str:
    return f"{flag} {path}" if flag else str(path)


def _parent(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _check_parent(path: Path, label: str) -> Path:
    parent = _parent(path)
    if not parent.exists():
        raise OutputPathError(f"cannot write {label}: the folder {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"cannot write {label}: {parent} is not a folder")
    return parent


@dataclass
class StagedFile:
    """An output file reserved by :meth:`Outputs.file`; fill it with :meth:`write_text`."""

    final: Path
    tmp: Path
    label: str

    def write_text(self, text: str) -> None:
        self.write_chunks((text,))

    def write_chunks(self, chunks: Iterable[str]) -> None:
        """Writes the pieces in order (a large output without holding all of it in memory)."""
        try:
            with open(self.tmp, "w", encoding="utf-8", newline="") as f:
                for chunk in chunks:
                    f.write(chunk)
        except OSError as e:
            raise OutputPathError(f"cannot write {self.label}: {_reason(e)}") from None


@dataclass
class _Manifest:
    files: Dict[str, str] = field(default_factory=dict)  # relative posix path -> sha256

    @staticmethod
    def _valid(rel: str) -> bool:
        p = PurePosixPath(rel)
        return (
            bool(rel)
            and not p.is_absolute()
            and ".." not in p.parts
            and "." not in p.parts
            and rel != MANIFEST
            and "\\" not in rel
        )

    @classmethod
    def read(cls, directory: Path, label: str) -> "_Manifest":
        path = directory / MANIFEST
        if not path.exists():
            return cls()
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, UnicodeDecodeError):
            doc = None
        if not isinstance(doc, dict) or doc.get("written_by") != _MANIFEST_TAG or not isinstance(doc.get("files"), dict):
            raise OutputPathError(
                f"cannot write {label}: {path} is not a manifest written by robot-stiffness; "
                "remove it or choose another folder"
            )
        files = {str(k): str(v) for k, v in doc["files"].items() if isinstance(k, str) and cls._valid(k)}
        return cls(files)

    def text(self) -> str:
        from . import __version__

        doc = {
            "written_by": _MANIFEST_TAG,
            "version": __version__,
            "note": "files robot-stiffness wrote here; with --force it replaces or removes only these, "
            "and only while unchanged",
            "files": dict(sorted(self.files.items())),
        }
        return json.dumps(doc, indent=2) + "\n"


def _owned(directory: Path, rel: str, manifest: _Manifest) -> bool:
    """True when ``directory/rel`` is a regular file the tool wrote and nobody changed since."""
    path = directory / rel
    if rel not in manifest.files or path.is_symlink() or not path.is_file():
        return False
    try:
        return _sha256(path) == manifest.files[rel]
    except OSError:
        return False


class StagedDirectory:
    """An output folder reserved by :meth:`Outputs.directory`: fill :attr:`path`, then commit."""

    def __init__(self, final: Path, force: bool, label: str, expected: Sequence[str]) -> None:
        self.final = final
        self.label = label
        self.force = force
        self.existed = final.exists() or final.is_symlink()
        if self.existed:
            if not final.is_dir():
                raise OutputPathError(f"cannot write {label}: it exists and is not a folder")
            if os.listdir(final) and not force:
                raise OutputPathError(
                    f"{label} is not empty; pass --force to replace only the files robot-stiffness wrote "
                    "there earlier (everything else is left alone), or choose another folder"
                )
            self._check_conflicts(list(expected))
            parent = final
            prefix = ".robot-stiffness.tmp-"
        else:
            parent = _check_parent(final, label)
            prefix = f".{final.name}.tmp-"
        try:
            self.path = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        except OSError as e:
            raise OutputPathError(f"cannot write {label}: {_reason(e)}") from None

    def _check_conflicts(self, names: Iterable[str]) -> _Manifest:
        """Refuse when a file the tool is about to write or remove is not its own."""
        manifest = _Manifest.read(self.final, self.label)
        for rel in sorted(set(names) | set(manifest.files)):
            path = self.final / rel
            for up in reversed(list(PurePosixPath(rel).parents)[:-1]):
                below = self.final / up
                if below.is_symlink() or (below.exists() and not below.is_dir()):
                    raise OutputPathError(f"cannot write {self.label}: {below} is in the way (not a folder)")
            if not (path.exists() or path.is_symlink()):
                continue
            if rel in manifest.files:
                if not _owned(self.final, rel, manifest):
                    raise OutputPathError(
                        f"cannot write {self.label}: {path} was changed since robot-stiffness wrote it; "
                        "move it away or delete it first"
                    )
            elif path.is_dir() and not path.is_symlink():
                raise OutputPathError(f"cannot write {self.label}: {path} is a folder in the way")
            else:
                raise OutputPathError(
                    f"cannot write {self.label}: {path} exists and was not written by robot-stiffness; "
                    "move it away or choose another folder"
                )
        return manifest

    def _staged_files(self) -> List[str]:
        out = []
        for root, _dirs, files in os.walk(self.path):
            for name in files:
                out.append(Path(root, name).relative_to(self.path).as_posix())
        return sorted(out)

    def precheck(self) -> None:
        """The checks :meth:`commit` makes, without writing (run for every output first)."""
        if self.final.exists() or self.final.is_symlink():
            if not self.final.is_dir():
                raise OutputPathError(f"cannot write {self.label}: it exists and is not a folder")
            self._check_conflicts(self._staged_files())

    def commit(self) -> None:
        written = self._staged_files()
        new = _Manifest({rel: _sha256(self.path / rel) for rel in written})
        dir_mode = 0o777 & ~_UMASK
        file_mode = 0o666 & ~_UMASK
        for root, dirs, files in os.walk(self.path):
            for d in dirs:
                os.chmod(Path(root, d), dir_mode)
            for f in files:
                os.chmod(Path(root, f), file_mode)
        if not self.existed and not (self.final.exists() or self.final.is_symlink()):
            (self.path / MANIFEST).write_text(new.text(), encoding="utf-8")
            os.chmod(self.path / MANIFEST, file_mode)
            os.chmod(self.path, dir_mode)
            try:
                os.rename(self.path, self.final)
            except OSError as e:
                raise OutputPathError(f"cannot write {self.label}: {_reason(e)}") from None
            return
        if not self.final.is_dir():
            raise OutputPathError(f"cannot write {self.label}: it exists and is not a folder")
        # Merge into the existing folder: check again (the user may have changed it meanwhile).
        old = self._check_conflicts(written)
        for rel in written:
            dst = self.final / rel
            dst.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self.path / rel, dst)
        for rel in sorted(set(old.files) - set(written)):
            if _owned(self.final, rel, old):
                (self.final / rel).unlink()
                self._remove_empty_parents(rel)
        merged = _Manifest(dict(new.files))
        tmp_fd, tmp_name = tempfile.mkstemp(prefix=f"{MANIFEST}{TMP_MARK}", dir=self.path)
        with os.fdopen(tmp_fd, "w", encoding="utf-8") as stream:
            stream.write(merged.text())
        os.chmod(tmp_name, file_mode)
        os.replace(tmp_name, self.final / MANIFEST)
        shutil.rmtree(self.path, ignore_errors=True)  # our own temporary folder (empty by now)

    def _remove_empty_parents(self, rel: str) -> None:
        parent = (self.final / rel).parent
        while parent != self.final and self.final in parent.parents:
            try:
                parent.rmdir()  # only succeeds when empty
            except OSError:
                return
            parent = parent.parent

    def discard(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)  # our own temporary folder


class Outputs:
    """The outputs of one command: reserve them up front, commit them at the end.

    ``inputs`` are the user's input files; an output that is one of them is refused. Thread
    safe: :meth:`discard` may race with nothing else because only the main thread touches files.
    """

    def __init__(self, inputs: Sequence[Optional[PathLike]] = ()) -> None:
        self._inputs = [Path(p) for p in inputs if p is not None]
        self._files: List[StagedFile] = []
        self._dirs: List[StagedDirectory] = []
        self._finals: Set[str] = set()
        self._lock = threading.Lock()
        #: True once :meth:`commit` has put every output in place.
        self.committed = False

    def _claim(self, final: Path, label: str) -> None:
        key = os.path.normcase(os.path.abspath(final))
        if key in self._finals:
            raise OutputPathError(f"{label} is given as two different outputs")
        for inp in self._inputs:
            if _same_file(final, inp) or os.path.abspath(final) == os.path.abspath(inp):
                raise OutputPathError(f"{label} is an input file; choose another output name")
        self._finals.add(key)

    def file(self, final: PathLike, flag: Optional[str] = None) -> StagedFile:
        """Reserve the output file ``final``; ``flag`` (e.g. ``--json``) names it in messages."""
        if not os.fspath(final):
            raise OutputPathError(f"{flag or 'output'}: empty file name")
        path = Path(final)
        label = _label(path, flag)
        if path.is_dir():
            raise OutputPathError(f"cannot write {label}: it is a folder; give a file name")
        _check_parent(path, label)
        self._claim(path, label)
        with self._lock, signals_deferred():
            try:
                fd, name = tempfile.mkstemp(prefix=f".{path.name}{TMP_MARK}", dir=_parent(path))
            except OSError as e:
                raise OutputPathError(f"cannot write {label}: {_reason(e)}") from None
            os.close(fd)
            staged = StagedFile(path, Path(name), label)
            self._files.append(staged)
        return staged

    def directory(
        self, final: PathLike, *, force: bool = False, flag: Optional[str] = None, expected: Sequence[str] = ()
    ) -> StagedDirectory:
        """Reserve the output folder ``final`` (see the module docstring). ``expected`` are the
        relative names the command will write, checked against the user's files up front."""
        if not os.fspath(final):
            raise OutputPathError(f"{flag or 'output folder'}: empty folder name")
        path = Path(final)
        label = _label(path, flag)
        for inp in self._inputs:
            if _same_file(path, inp):
                raise OutputPathError(f"{label} is an input file; choose another output folder")
        self._claim(path, label)
        with self._lock, signals_deferred():
            staged = StagedDirectory(path, force, label, expected)
            self._dirs.append(staged)
        return staged

    def commit(self) -> None:
        """Rename every staged output into place."""
        with self._lock, signals_deferred():
            for d in self._dirs:  # a refused folder must not leave the files half-committed
                d.precheck()
            mode = 0o666 & ~_UMASK
            for f in self._files:
                os.chmod(f.tmp, mode)
                try:
                    os.replace(f.tmp, f.final)
                except OSError as e:
                    raise OutputPathError(f"cannot write {f.label}: {_reason(e)}") from None
            self._files.clear()
            while self._dirs:
                self._dirs[0].commit()
                self._dirs.pop(0)
            self.committed = True

    def discard(self) -> None:
        """Remove every temporary that was not committed (idempotent)."""
        with self._lock, signals_deferred():
            for f in self._files:
                try:
                    f.tmp.unlink()
                except OSError:
                    pass
            self._files.clear()
            for d in self._dirs:
                d.discard()
            self._dirs.clear()

    def staged(self) -> List[Tuple[Path, Path]]:
        """(temporary, final) pairs still pending (for tests)."""
        return [(f.tmp, f.final) for f in self._files] + [(d.path, d.final) for d in self._dirs]
