"""Count what a process does with an FMU file: reads from disk, zip archives opened, XML parsed.

Independent of fmuid's own parse counter: it wraps the standard library's and lxml's entry
points (``open``, ``zipfile.ZipFile``, ``ElementTree`` and ``lxml.etree`` parsing), whoever
calls them (fmuid or fmpy).
"""

from __future__ import annotations

import builtins
import collections
import io
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any

from lxml import etree

_PARSERS = [(ET, name) for name in ("fromstring", "parse", "XML", "iterparse")] + [
    (etree, name) for name in ("parse", "fromstring", "XML", "iterparse")
]


class FmuSpy:
    """Count, while the block runs, what this process does with the file ``fmu``.

    ``counts["disk"]``: opens of the file; ``counts["zip"]``: zip archives opened on the file or
    on bytes in memory; ``counts["xml"]``: XML documents parsed (by any caller).
    """

    def __init__(self, fmu: str | Path) -> None:
        self.fmu = str(fmu)
        self.counts: collections.Counter[str] = collections.Counter()
        self._saved: list[tuple[Any, str, Any]] = []

    def _wrap(self, owner: Any, name: str, key: str, counts_call: Any) -> None:
        real = getattr(owner, name)
        self._saved.append((owner, name, real))

        def counted(*args: Any, **kwargs: Any) -> Any:
            self.counts[key] += counts_call(*args)
            return real(*args, **kwargs)

        setattr(owner, name, counted)

    def __enter__(self) -> FmuSpy:
        self._wrap(io, "open", "disk", lambda file, *_: str(file) == self.fmu)
        self._wrap(builtins, "open", "disk", lambda file, *_: str(file) == self.fmu)
        real_init = zipfile.ZipFile.__init__
        self._saved.append((zipfile.ZipFile, "__init__", real_init))

        def zip_init(archive: Any, file: Any, *args: Any, **kwargs: Any) -> None:
            self.counts["zip"] += hasattr(file, "read") or str(file) == self.fmu
            real_init(archive, file, *args, **kwargs)

        zipfile.ZipFile.__init__ = zip_init  # type: ignore[method-assign]
        for owner, name in _PARSERS:
            self._wrap(owner, name, "xml", lambda *_: 1)
        return self

    def __exit__(self, *exc: object) -> None:
        for owner, name, real in reversed(self._saved):
            setattr(owner, name, real)
        self._saved.clear()

    def seen(self) -> tuple[int, int, int]:
        """Return (disk reads, zip opens, XML parses) so far."""
        return self.counts["disk"], self.counts["zip"], self.counts["xml"]
