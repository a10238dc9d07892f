"""Output files and folders that never lose anything the tool did not write.

Every output is *reserved* before the long computation (the checks run then, and a temporary
file or folder is created, which proves the location is writable) and *committed* at the very
end by renaming (the checks run again just before); on any error, Ctrl-C or SIGTERM
:meth:`Outputs.discard` removes the temporaries and nothing else.

* No output may be one of the command's inputs (``Outputs(inputs=...)``, which include the
  files a model file names, such as its URDF). Paths are compared by file identity
  (``os.path.samefile``: the same device and inode) and by resolved path, not as strings, so
  ``./data.csv``, a symbolic link to the input and a hard link to it are all the input.
* A file (``--json``, ``--truth``, ``--out``, ``--plot``, ``--save``, ``OUT.csv``) is staged as
  ``.NAME.tmp-*`` next to it and renamed over it on commit. Its name must be missing or a
  regular file: a folder, FIFO, character or block device or socket (or a symbolic link to one,
  such as ``/dev/null`` or ``/dev/stdout``) is refused and left as it is. An existing file is
  replaced only with ``force`` (``--force``); without it the file is never replaced, even if it
  appears during the run (committed with a hard link, which fails on an existing name).
  A symbolic link is refused whatever it points to, and left as it is: a link may point
  anywhere (``/dev/stdout`` links to the terminal, a pipe or the very file the shell redirects
  stdout to), so the tool writes a file only under its own name.
* A folder (``--report DIR``, ``demo --out DIR``):

  - missing: staged as ``.DIR.tmp-*`` next to it and renamed to DIR on commit;
  - empty: filled on commit;
  - not empty: refused unless ``force``; then only the files listed in the tool's manifest
    ``DIR/.robot-stiffness-manifest.json`` (written by an earlier run, with a SHA-256 per file)
    and still unchanged are replaced or removed. Any other file — the user's data, notes,
    subfolders, the command's inputs — is left byte-identical; a name the tool needs that is
    taken by such a file is refused before anything is written.

  The manifest proves which files the tool wrote only when its signature verifies: an
  HMAC-SHA256 of the folder's resolved path and the file list under a per-user secret key,
  created once (mode 0600) as ``manifest.key`` in ``$ROBOT_STIFFNESS_STATE_DIR``, else
  ``$XDG_STATE_HOME/robot-stiffness``, else ``~/.local/state/robot-stiffness`` — outside every
  output folder. A manifest that does not verify (hand-written, edited, copied from another
  folder, written on another account) or a key that cannot be read refuses the folder with
  ``force``: nothing it names is touched, and the user is asked to remove the files themselves.

Nothing here calls ``shutil.rmtree`` on anything but the tool's own temporary folders.
"""

from __future__ import annotations

import errno
import hashlib
import hmac
import json
import os
import re
import secrets
import shutil
import stat
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Set, Tuple, Union

from ._errors import OutputPathError, StiffnessError
from ._interrupt import signals_deferred

__all__ = ["Outputs", "StagedFile", "StagedDirectory", "MANIFEST", "TMP_MARK", "KEY_FILE", "STATE_DIR_ENV",
           "key_path"]

PathLike = Union[str, "os.PathLike[str]"]
#: An input: a path, or a path and what it is (``("u.urdf", "the URDF m.json names")``).
Input = Union[PathLike, Tuple[PathLike, str]]

#: The manifest of the files the tool wrote into an output folder.
MANIFEST = ".robot-stiffness-manifest.json"
#: Every temporary name contains this mark (``.NAME.tmp-XXXXXXXX``).
TMP_MARK = ".tmp-"
_MANIFEST_TAG = "robot-stiffness output manifest"
#: A manifest larger than this is not one of the tool's (it lists a handful of files).
_MANIFEST_MAX_BYTES = 1 << 20
#: The per-user key that signs manifests, in the state folder (see the module docstring).
KEY_FILE = "manifest.key"
#: Environment variable naming the state folder (tests; a user who wants the key elsewhere).
STATE_DIR_ENV = "ROBOT_STIFFNESS_STATE_DIR"
_KEY_TEXT = re.compile(r"[0-9a-f]{64}")


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
    if e.errno == errno.ELOOP:
        return "it is a symbolic link"
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
    """The same file: same device and inode (through symbolic links; hard links included)."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _same_path(a: Path, b: Path) -> bool:
    """The same location, for names that need not exist yet (``./x`` and ``x``, links resolved)."""
    try:
        if os.path.normcase(os.path.abspath(a)) == os.path.normcase(os.path.abspath(b)):
            return True
        return os.path.normcase(os.path.realpath(a)) == os.path.normcase(os.path.realpath(b))
    except (OSError, ValueError):
        return False


def _special_kind(mode: int) -> Optional[str]:
    """What a file that is neither a regular file nor a folder is, for messages."""
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return "not a regular file"


def _check_parent(path: Path, label: str) -> Path:
    parent = _parent(path)
    if not parent.exists():
        raise OutputPathError(f"cannot write {label}: the folder {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"cannot write {label}: {parent} is not a folder")
    return parent


def _check_file(path: Path, label: str, force: bool, hint: str) -> None:
    """An output file's name must be missing or a regular file, and an existing one needs
    ``force``. A folder, a special file and a symbolic link (whatever it points to) are refused
    and left as they are: a link may point anywhere (``/dev/stdout`` is a link to the terminal,
    a pipe or the file the shell redirects to), so the tool never writes through one."""
    try:
        st = os.lstat(path)
    except OSError:
        return  # missing (or an unreachable folder: _check_parent says which)
    if stat.S_ISLNK(st.st_mode):
        real = os.path.realpath(path)
        try:
            kind = _special_kind(os.stat(path).st_mode)
            what = "a folder" if path.is_dir() else (kind or "a regular file")
            to = f"{real}, {what}"
        except OSError:
            to = f"{real}, which does not exist"
        raise OutputPathError(
            f"cannot write {label}: it is a symbolic link (to {to}); outputs must be regular files, "
            "written under their own name: give the file's own path (the link is left as it is)"
        )
    if stat.S_ISDIR(st.st_mode):
        raise OutputPathError(f"cannot write {label}: it is a folder; give a file name")
    kind = _special_kind(st.st_mode)
    if kind is not None:
        raise OutputPathError(
            f"cannot write {label}: it is {kind}; outputs must be regular files, and it is left as it is"
        )
    if not force:
        raise OutputPathError(f"cannot write {label}: the file exists; pass {hint} to replace it")


# ----------------------------------------------------------------------------- manifest key


class _NoKey(Exception):
    """The manifest key cannot be read or created (the message says why)."""


def key_path() -> Path:
    """The file of the per-user key that signs output manifests (see the module docstring)."""
    env = os.environ.get(STATE_DIR_ENV)
    if env:
        return Path(env) / KEY_FILE
    xdg = os.environ.get("XDG_STATE_HOME")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "robot-stiffness" / KEY_FILE
    try:
        home = Path.home()
    except (RuntimeError, KeyError):  # no HOME and no password entry
        raise _NoKey("there is no home folder to keep the key in") from None
    return home / ".local" / "state" / "robot-stiffness" / KEY_FILE


def _read_key(path: Path) -> bytes:
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    fd = os.open(path, flags)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _NoKey(f"{path} is not a regular file")
        if hasattr(os, "getuid") and (st.st_uid != os.getuid() or st.st_mode & 0o077):
            # Anyone else who can read it could sign a manifest in the user's name.
            raise _NoKey(f"{path} must belong to you and be readable by you only (chmod 600)")
        data = os.read(fd, 256)
    finally:
        os.close(fd)
    text = data.decode("ascii", "replace").strip()
    if not _KEY_TEXT.fullmatch(text):
        raise _NoKey(f"{path} is not a robot-stiffness key")
    return bytes.fromhex(text)


def _manifest_key(create: bool) -> bytes:
    """The key (created on first use when ``create``); raises :class:`_NoKey` saying why not."""
    path = key_path()
    try:
        return _read_key(path)
    except FileNotFoundError:
        if not create:
            raise _NoKey(f"the key {path} does not exist") from None
    except OSError as e:
        raise _NoKey(f"the key {path} cannot be read ({_reason(e)})") from None
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{KEY_FILE}{TMP_MARK}", dir=path.parent)  # mode 0600
        try:
            with os.fdopen(fd, "w", encoding="ascii") as f:
                f.write(secrets.token_hex(32) + "\n")
            try:
                os.link(tmp, path)  # never replaces a key another process created meanwhile
            except FileExistsError:
                pass
            except OSError:
                if not path.exists():  # no hard links on this file system
                    os.replace(tmp, path)
        finally:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        return _read_key(path)
    except OSError as e:
        raise _NoKey(f"the key {path} cannot be created ({_reason(e)})") from None


def _signature(key: bytes, directory: Path, files: Dict[str, str]) -> str:
    """HMAC-SHA256 of the folder's resolved path and its file list (names and SHA-256)."""
    doc = {"written_by": _MANIFEST_TAG, "folder": os.path.realpath(directory), "files": files}
    message = json.dumps(doc, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode("ascii")
    return hmac.new(key, message, hashlib.sha256).hexdigest()


# ----------------------------------------------------------------------------- files


@dataclass
class StagedFile:
    """An output file reserved by :meth:`Outputs.file`; fill it with :meth:`write_text`.
    ``force``: it may replace an existing regular file on commit."""

    final: Path
    tmp: Path
    label: str
    force: bool = True

    def write_text(self, text: str) -> None:
        self.write_chunks((text,))

    def write_with(self, write: Callable[[Path], None]) -> None:
        """Lets ``write(path)`` (a writer of the core) fill the staged file; an ``OSError`` it
        raises is worded as :meth:`write_chunks` words one."""
        try:
            write(self.tmp)
        except StiffnessError:
            raise
        except OSError as e:
            raise OutputPathError(f"cannot write {self.label}: {_reason(e)}") from None

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
    def read(cls, directory: Path, label: str, hint: str = "--force") -> "_Manifest":
        """The manifest of ``directory`` (empty when there is none); refused unless it is a
        manifest the tool wrote for this folder (its signature verifies)."""
        path = directory / MANIFEST
        try:
            st = os.lstat(path)
        except FileNotFoundError:
            return cls()
        except OSError as e:
            raise OutputPathError(f"cannot write {label}: {path}: {_reason(e)}") from None
        doc = None
        if stat.S_ISREG(st.st_mode) and st.st_size <= _MANIFEST_MAX_BYTES:
            try:
                doc = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError, UnicodeDecodeError, RecursionError):
                doc = None
        files = doc.get("files") if isinstance(doc, dict) else None
        if (
            not isinstance(doc, dict)
            or doc.get("written_by") != _MANIFEST_TAG
            or not isinstance(files, dict)
            or not all(isinstance(k, str) and isinstance(v, str) for k, v in files.items())
        ):
            raise OutputPathError(
                f"cannot write {label}: {path} is not a manifest written by robot-stiffness; "
                "remove it or choose another folder"
            )
        refuse = (f"so {hint} replaces nothing there; remove the folder's files yourself or choose another "
                  "folder")
        try:
            key = _manifest_key(create=False)
        except _NoKey as e:
            raise OutputPathError(
                f"cannot write {label}: which files of {directory} robot-stiffness wrote cannot be proved "
                f"({e}), {refuse}"
            ) from None
        mac = doc.get("signature")
        if not isinstance(mac, str) or not hmac.compare_digest(mac, _signature(key, directory, files)):
            raise OutputPathError(
                f"cannot write {label}: {path} is not a manifest written by robot-stiffness for this folder "
                f"on this account (its signature does not verify), {refuse}"
            )
        return cls({k: v for k, v in files.items() if cls._valid(k)})

    def text(self, directory: Path) -> str:
        """The manifest's text for the folder ``directory``, signed when the key is available
        (without it a later ``force`` replaces nothing there)."""
        from . import __version__

        files = dict(sorted(self.files.items()))
        doc: Dict[str, object] = {
            "written_by": _MANIFEST_TAG,
            "version": __version__,
            "note": "files robot-stiffness wrote here; with --force it replaces or removes only these, "
            "only while unchanged, and only while the signature verifies under the user's key",
            "files": files,
        }
        try:
            doc["signature"] = _signature(_manifest_key(create=True), directory, files)
        except _NoKey as e:
            doc["note"] = f"unsigned ({e}): --force replaces nothing in this folder"
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

    def __init__(self, final: Path, force: bool, label: str, expected: Sequence[str],
                 inputs: Sequence[Tuple[Path, Optional[str]]] = (), hint: str = "--force") -> None:
        self.final = final
        self.label = label
        self.force = force
        self.hint = hint
        self._inputs = list(inputs)
        self.existed = final.exists() or final.is_symlink()
        if self.existed:
            if not final.is_dir():
                raise OutputPathError(f"cannot write {label}: it exists and is not a folder")
            if os.listdir(final) and not force:
                raise OutputPathError(
                    f"{label} is not empty; pass {hint} to replace only the files robot-stiffness wrote "
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

    def _is_input(self, path: Path) -> bool:
        return any(_same_file(path, inp) for inp, _ in self._inputs)

    def _check_conflicts(self, names: Iterable[str]) -> _Manifest:
        """Refuse when a file the tool is about to write or remove is not its own, or is one of
        the command's inputs that it would replace."""
        manifest = _Manifest.read(self.final, self.label, self.hint)
        writing = set(names)
        for rel in sorted(writing | set(manifest.files)):
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
                if rel in writing and self._is_input(path):
                    raise OutputPathError(
                        f"cannot write {self.label}: {path} is an input file of this command; choose another "
                        "output folder"
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
            (self.path / MANIFEST).write_text(new.text(self.final), encoding="utf-8")
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
        merged = _Manifest(dict(new.files))
        for rel in sorted(set(old.files) - set(written)):
            if _owned(self.final, rel, old):
                if self._is_input(self.final / rel):  # the tool's file, read by this command: kept
                    merged.files[rel] = old.files[rel]
                    continue
                (self.final / rel).unlink()
                self._remove_empty_parents(rel)
        tmp_fd, tmp_name = tempfile.mkstemp(prefix=f"{MANIFEST}{TMP_MARK}", dir=self.path)
        with os.fdopen(tmp_fd, "w", encoding="utf-8") as stream:
            stream.write(merged.text(self.final))
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


def _place(f: StagedFile, hint: str) -> None:
    """Renames the staged file into place; without ``force`` never over an existing name."""
    dst = f.final
    if f.force:
        os.replace(f.tmp, dst)
        return
    try:
        os.link(f.tmp, dst)  # atomic, and fails if the name appeared during the run
    except FileExistsError:
        raise OutputPathError(f"cannot write {f.label}: the file exists; pass {hint} to replace it") from None
    except OSError as e:
        if e.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EMLINK, errno.ENOSYS, errno.EXDEV):
            raise
        os.replace(f.tmp, dst)  # no hard links on this file system: the check just made guards
        return
    try:
        os.unlink(f.tmp)
    except OSError:
        pass


class Outputs:
    """The outputs of one command: reserve them up front, commit them at the end.

    ``inputs`` are the user's input files (a path, or a ``(path, what)`` pair for messages); an
    output that is one of them is refused. ``force`` lets output files replace existing ones
    (``--force``); ``hint`` is how messages spell it (``force=True`` in the Python API). Thread
    safe: :meth:`discard` may race with nothing else because only the main thread touches files.
    """

    def __init__(self, inputs: Sequence[Optional[Input]] = (), *, force: bool = False,
                 hint: str = "--force") -> None:
        self._inputs: List[Tuple[Path, Optional[str]]] = []
        for item in inputs:
            if item is not None:
                self.add_input(*(item if isinstance(item, tuple) else (item,)))
        self.force = bool(force)
        self.hint = hint
        self._files: List[StagedFile] = []
        self._dirs: List[StagedDirectory] = []
        self._finals: Set[str] = set()
        self._claimed: List[Path] = []
        self._lock = threading.Lock()
        #: True once :meth:`commit` has put every output in place.
        self.committed = False

    def add_input(self, path: PathLike, what: Optional[str] = None) -> None:
        """One more input file (``what`` says what it is in messages: "the URDF m.json names")."""
        if os.fspath(path):
            self._inputs.append((Path(path), what))

    def _check_not_input(self, path: Path, label: str, noun: str = "output name") -> None:
        for inp, what in self._inputs:
            if _same_file(path, inp) or _same_path(path, inp):
                detail = f" ({what})" if what else ""
                raise OutputPathError(f"{label} is an input file{detail}; choose another {noun}")

    def _claim(self, final: Path, label: str) -> None:
        key = os.path.normcase(os.path.abspath(final))
        if key in self._finals or any(_same_file(final, c) or _same_path(final, c) for c in self._claimed):
            raise OutputPathError(f"{label} is given as two different outputs")
        self._check_not_input(final, label)
        self._finals.add(key)
        self._claimed.append(final)

    def file(self, final: PathLike, flag: Optional[str] = None, *, force: Optional[bool] = None) -> StagedFile:
        """Reserve the output file ``final``; ``flag`` (e.g. ``--json``) names it in messages;
        ``force`` (default: the one given to the constructor) lets it replace an existing file."""
        if not os.fspath(final):
            raise OutputPathError(f"{flag or 'output'}: empty file name")
        if os.fspath(final) == "-":
            # `-` would otherwise become a file named "-": no output streams to stdout.
            raise OutputPathError(
                f"{flag or 'output'} -: writing to standard output is not supported; give a file name"
            )
        path = Path(final)
        label = _label(path, flag)
        replace = self.force if force is None else bool(force)
        self._check_not_input(path, label)  # first: "is an input file" says more than "exists"
        _check_file(path, label, replace, self.hint)
        _check_parent(path, label)
        self._claim(path, label)
        with self._lock, signals_deferred():
            try:
                fd, name = tempfile.mkstemp(prefix=f".{path.name}{TMP_MARK}", dir=_parent(path))
            except OSError as e:
                raise OutputPathError(f"cannot write {label}: {_reason(e)}") from None
            os.close(fd)
            staged = StagedFile(path, Path(name), label, replace)
            self._files.append(staged)
        return staged

    def directory(
        self, final: PathLike, *, force: Optional[bool] = None, flag: Optional[str] = None,
        expected: Sequence[str] = ()
    ) -> StagedDirectory:
        """Reserve the output folder ``final`` (see the module docstring). ``expected`` are the
        relative names the command will write, checked against the user's files up front."""
        if not os.fspath(final):
            raise OutputPathError(f"{flag or 'output folder'}: empty folder name")
        path = Path(final)
        label = _label(path, flag)
        self._check_not_input(path, label, "output folder")
        self._claim(path, label)
        with self._lock, signals_deferred():
            replace = self.force if force is None else bool(force)
            staged = StagedDirectory(path, replace, label, expected, self._inputs, self.hint)
            self._dirs.append(staged)
        return staged

    def _precheck(self, f: StagedFile) -> None:
        """The checks of :meth:`file` again, just before the rename (the user may have replaced
        the name by a FIFO, a link or a file meanwhile, or linked it to an input)."""
        self._check_not_input(f.final, f.label)
        _check_file(f.final, f.label, f.force, self.hint)

    def commit(self) -> None:
        """Rename every staged output into place."""
        with self._lock, signals_deferred():
            for f in self._files:  # a refused output must not leave the others half-committed
                self._precheck(f)
            for d in self._dirs:
                d.precheck()
            mode = 0o666 & ~_UMASK
            for f in self._files:
                os.chmod(f.tmp, mode)
                try:
                    _place(f, self.hint)
                except OSError as e:
                    if isinstance(e, OutputPathError):
                        raise
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
