"""A folder of results keyed by what they were computed from, so an interrupted or extended
run redoes only what is missing (``curves``: one entry per manifest row; ``criticize``: one
per candidate effect; docs/outputs.md, "The cache").

An entry is one file ``<key>.pkl``: a header line ``turgorbayes-cache/1 <sha256> <size>``
(the sha256 and size in bytes of the payload after it) and the pickled value, the very object
a worker process would have sent back, so a cached run's outputs are those of an uncached one
to the byte. It is written to a temporary file and renamed into place (:func:`os.replace`),
so a killed run never leaves a half entry under an entry's name; one that is damaged anyway
(truncated, altered) fails its sha256, is reported in one line, deleted and computed again,
never used.

The key (:func:`key`) is the sha256 of the JSON of everything the value depends on: the
input's bytes (:func:`file_sha256`), the settings, the seed, the package version and, in a git
checkout, the commit and its uncommitted changes (:func:`turgorbayes.provenance.source_digest`). Like
every pickle, an entry is trusted as code: do not use a cache folder from someone else.
"""

import functools
import hashlib
import json
import os
import pickle
from pathlib import Path

from turgorbayes import __version__
from turgorbayes.provenance import source_digest

__all__ = ["FORMAT", "MISSING", "Cache", "file_sha256", "key"]

#: The first word of every entry's header (changes when the layout does).
FORMAT = "turgorbayes-cache/1"

#: What :meth:`Cache.get` returns for a key without a usable entry.
MISSING = object()


def file_sha256(path, chunk=1 << 20):
    """The sha256 hex digest of a file's bytes (read ``chunk`` bytes at a time)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            digest.update(block)
    return digest.hexdigest()


def key(kind, **parts):
    """The key of an entry: the sha256 of the JSON of ``kind``, the package version and
    ``parts`` (JSON-able; paths and other objects as ``str``).

    Parameters
    ----------
    kind : str
        What is cached (``"curve"``, ``"candidate"``), so two kinds never share a key.
    **parts
        Everything the value depends on.

    Returns
    -------
    str
        64 hex digits.
    """
    text = json.dumps({"kind": kind, "version": __version__, "source": _source(), **parts},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@functools.cache
def _source():
    """The package's source state (:func:`turgorbayes.provenance.source_digest`), once per run:
    in a git checkout an edit of the code changes every key, so no entry of other code is
    reused."""
    return source_digest()


class Cache:
    """Entries of one kind in one folder.

    Parameters
    ----------
    folder : path-like
        Created at the first entry written.
    report : callable, optional
        ``report(line)`` with the one-line message of each damaged entry (default: ignored).

    Attributes
    ----------
    hits, misses, damaged : int
        Entries found, not found, and found damaged (counted in ``misses`` too).
    """

    def __init__(self, folder, report=None):
        self.folder = Path(folder)
        self.report = report or (lambda line: None)
        self.hits = self.misses = self.damaged = 0

    def path(self, entry_key):
        """The file of the entry ``entry_key``."""
        return self.folder / f"{entry_key}.pkl"

    def get(self, entry_key):
        """The value stored under ``entry_key``, or :data:`MISSING` (no entry, or a damaged
        one: reported, deleted)."""
        path = self.path(entry_key)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            self.misses += 1
            return MISSING
        try:
            value = _decode(data)
        except ValueError as err:
            self.misses += 1
            self.damaged += 1
            self.report(f"warning: damaged cache entry {path} ({err}); computing it again")
            path.unlink(missing_ok=True)
            return MISSING
        self.hits += 1
        return value

    def put(self, entry_key, value):
        """Store ``value`` under ``entry_key``, atomically (a temporary file renamed)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.path(entry_key)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(_encode(value))
        os.replace(tmp, path)


def _encode(value):
    payload = pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)
    header = f"{FORMAT} {hashlib.sha256(payload).hexdigest()} {len(payload)}\n"
    return header.encode() + payload


def _decode(data):
    """The value of an entry's bytes.

    Raises
    ------
    ValueError
        Not an entry of this format, or its payload's size or sha256 is not the header's, or
        it does not unpickle (written by a version whose classes have changed).
    """
    head, _, payload = data.partition(b"\n")
    words = head.decode("ascii", errors="replace").split(" ")
    if len(words) != 3 or words[0] != FORMAT or not words[2].isdigit():
        raise ValueError("no valid header")
    if len(payload) != int(words[2]):
        raise ValueError(f"{len(payload)} bytes of {words[2]}")
    if hashlib.sha256(payload).hexdigest() != words[1]:
        raise ValueError("sha256 mismatch")
    try:
        return pickle.loads(payload)
    except Exception as err:  # noqa: BLE001 - any unpickling failure makes the entry unusable
        raise ValueError(f"cannot be read: {type(err).__name__}") from None
