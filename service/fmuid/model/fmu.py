"""A loaded FMU: checks that it can run here and lists its variables with their FMI types.

Supported: FMI 2.0 or 3.0, co-simulation or model exchange, with a linux x86-64 binary.
"""

from __future__ import annotations

import copy
import hashlib
import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmpy.model_description import ModelDescription

from fmuid.errors import FmuError
from fmuid.model.annotations import fmuid_annotation_of
from fmuid.model.archive import open_archive, read_description
from fmuid.model.variable import USABLE, Variable, from_fmpy
from fmuid.model.world import registry

logger = logging.getLogger(__name__)

CO_SIMULATION = "CoSimulation"
MODEL_EXCHANGE = "ModelExchange"
INTERFACES: dict[str | None, str | None] = {
    None: None,
    "auto": None,
    "co_simulation": CO_SIMULATION,
    "model_exchange": MODEL_EXCHANGE,
    CO_SIMULATION: CO_SIMULATION,
    MODEL_EXCHANGE: MODEL_EXCHANGE,
}
"""Accepted names of the interface to drive (the spec's spelling and FMI's); auto/None:
co-simulation when the FMU has it, else model exchange."""
SPEC_NAMES = {CO_SIMULATION: "co_simulation", MODEL_EXCHANGE: "model_exchange"}
"""The spec's name of each FMI interface."""

BINARY_DIR = {"2.0": "binaries/linux64", "3.0": "binaries/x86_64-linux"}
_ROLE_HELP = {
    "parameters": "only Real/Float parameters can be fitted; set others under 'fixed'",
    "inputs": "inputs must be Real/Float, Integer, Enumeration or Boolean scalars",
    "outputs": "outputs must be Real/Float, Integer, Enumeration or Boolean scalars",
}
_FIXED_HELP = {
    "string": "give it a text value",
    "float": "give it a number",
    "integer": "give it a whole number",
    "boolean": "give it 0 or 1",
}


@dataclass(frozen=True)
class FmuFile:
    """What a process hands another so that it parses the FMU once: file, checksum, interface.

    A pickled :class:`FmuModel` travels as this; :func:`load_model` turns it back into the
    receiving process's one parsed model.
    """

    path: str
    sha256: str
    interface: str


def load_model(file: FmuFile) -> FmuModel:
    """Return this process's model of ``file``, parsing it on the first request only.

    The model is found by checksum and interface: once a worker has parsed a local copy of
    the FMU, the pickled models naming the submitter's path find that copy.

    Raises
    ------
    FmuError
        If the file is missing, invalid, or no longer has the checksum ``file.sha256``.

    """
    return registry().model(
        (file.sha256, file.interface),
        lambda: FmuModel(file.path, file.interface, sha256=file.sha256),
    )


def model_of_file(path: str | Path, interface: str | None = None) -> FmuModel:
    """Return this process's model of the file at ``path``, parsed again when the file changes.

    For a caller that holds only the path (a script simulating in a loop, a stage given a
    file); a change of the file's modification time or size makes it parse the file again.

    Raises
    ------
    FmuError
        If the file does not exist or is not a usable FMU (see :class:`FmuModel`).

    """
    try:
        st = Path(path).stat()
    except OSError as exc:
        raise FmuError(f"FMU {path} does not exist") from exc
    wanted = INTERFACES.get(interface, interface)
    key = (str(Path(path).resolve()), st.st_mtime_ns, st.st_size, wanted)
    return registry().file_model(key, lambda: FmuModel(path, interface))


class FmuModel:
    """An FMI 2.0 or 3.0 FMU (co-simulation or model exchange) with a linux x86-64 binary.

    The file is read, checked and hashed once, here; the model is then handed on (to the
    simulator, the problem, the result). Pickled, it travels as an :class:`FmuFile` and is
    parsed once in the receiving process (:func:`load_model`).

    Parameters
    ----------
    path
        The ``.fmu`` file.
    interface
        ``"co_simulation"`` (or ``"CoSimulation"``), ``"model_exchange"`` (or
        ``"ModelExchange"``), or ``"auto"``/None: co-simulation when the FMU has it (its own
        solver, as its exporter tuned it), else model exchange.
    sha256
        The checksum the file must have (the file a parent process parsed), or None.

    Attributes
    ----------
    path
        The ``.fmu`` file.
    sha256
        SHA-256 hex digest of the file.
    data
        The file's bytes, as read and hashed (its zip, opened on them once, is unpacked for
        each simulator by :meth:`extract`).
    model_name, fmi_version, guid, model_identifier
        From ``modelDescription.xml`` (``guid`` is the FMI 3.0 ``instantiationToken``).
    interface
        The FMI interface fmuid drives: ``CoSimulation`` or ``ModelExchange``.
    interfaces
        The FMI interfaces the FMU has (of those two).
    model_description
        fmpy's parsed model description.
    parameters, inputs, outputs
        Variables of every type by name, in file order (see :attr:`Variable.kind` for which
        types fmuid can use where).

    Raises
    ------
    FmuError
        If the file is not a zip archive, has entries escaping the extraction directory, is not
        FMI 2.0 or 3.0, lacks the requested interface, has no linux x86-64 binary, or does not
        have the checksum ``sha256``.

    """

    def __init__(
        self, path: str | Path, interface: str | None = None, *, sha256: str | None = None
    ) -> None:
        self.path = Path(path)
        self._resolved = str(self.path.resolve())
        archive = open_archive(self.path)
        self.sha256 = hashlib.sha256(archive.data).hexdigest()
        registry().count_parse()
        if sha256 is not None and sha256 != self.sha256:
            raise FmuError(
                f"{self.path}: the FMU changed: its sha256 is {self.sha256[:12]}..., "
                f"expected {sha256[:12]}..."
            )
        logger.debug("parsed %s (sha256 %s)", self.path, self.sha256[:12])
        parsed = read_description(self.path, archive.xml)
        description = parsed.fmpy
        self.data = archive.data
        self._zip = archive.zip
        self.annotation: Any = fmuid_annotation_of(parsed.root)
        """The ``<Model>`` element of the FMU's ``fmuid`` vendor annotation, or None."""
        self.model_description: ModelDescription = description
        self.interfaces = tuple(
            name
            for name, part in (
                (CO_SIMULATION, description.coSimulation),
                (MODEL_EXCHANGE, description.modelExchange),
            )
            if part is not None
        )
        self.interface = _choose_interface(self.path, self.interfaces, interface)
        self.model_name: str = description.modelName
        self.fmi_version: str = parsed.fmi_version
        self.guid: str = description.guid or description.instantiationToken or ""
        self._archive = frozenset(archive.zip.namelist())
        self.model_identifier: str = self._identifier()
        self.parameters: dict[str, Variable] = {}
        self.inputs: dict[str, Variable] = {}
        self.outputs: dict[str, Variable] = {}
        groups = {
            "parameter": self.parameters,
            "structuralParameter": self.parameters,
            "input": self.inputs,
            "output": self.outputs,
        }
        for v in description.modelVariables:
            group = groups.get(v.causality)
            if group is not None:
                group[v.name] = from_fmpy(v)

    @property
    def key(self) -> tuple[str, str, str]:
        """What identifies this model's simulators: checksum, resolved file, interface.

        The file is resolved when it is parsed (the key is asked for on every simulation).
        """
        return (self.sha256, self._resolved, self.interface)

    @property
    def file(self) -> FmuFile:
        """The file, checksum and interface another process parses this model from."""
        return FmuFile(str(self.path), self.sha256, self.interface)

    def __reduce__(self) -> tuple[object, tuple[FmuFile]]:
        """Pickle as the :class:`FmuFile`: the receiving process parses it once."""
        return (load_model, (self.file,))

    def __copy__(self) -> FmuModel:
        """Return a new object with this model's state (not the process's model of its file).

        Without it, :func:`copy.copy` would go through :meth:`__reduce__` and hand back the
        registry's model itself, which :meth:`with_interface` would then change for every holder.
        """
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        return other

    def extract(self, folder: str | Path) -> None:
        """Unpack the FMU, as read and hashed, into ``folder`` (the zip is not opened again)."""
        self._zip.extractall(folder)

    def with_interface(self, interface: str | None) -> FmuModel:
        """Return this model driving ``interface`` (as in the constructor), without re-parsing.

        Raises
        ------
        FmuError
            If the FMU lacks that interface.

        """
        chosen = _choose_interface(self.path, self.interfaces, interface)
        if chosen == self.interface:
            return self
        other = copy.copy(self)
        other.interface = chosen
        other.model_identifier = other._identifier()
        return other

    def _identifier(self) -> str:
        """Return the driven interface's model identifier, checking that its binary is there."""
        description = self.model_description
        kind = description.coSimulation if self.is_cosimulation else description.modelExchange
        binary = f"{BINARY_DIR[self.fmi_version]}/{kind.modelIdentifier}.so"
        if binary not in self._archive:
            raise FmuError(
                f"{self.path}: the FMI {self.fmi_version} FMU has no linux x86-64 binary "
                f"({binary} is missing; source-code-only FMUs are not compiled by fmuid)"
            )
        return str(kind.modelIdentifier)

    def interface_problem(self, wanted: str) -> str | None:
        """Say why a study cannot drive the interface ``wanted`` (a spec name), else None."""
        chosen = INTERFACES.get(wanted, wanted)
        if chosen is None or chosen in self.interfaces:
            return None
        has = " and ".join(SPEC_NAMES[i] for i in self.interfaces)
        return f'the FMU has no {wanted} interface (it has {has}); use "auto"'

    @property
    def is_cosimulation(self) -> bool:
        """Whether fmuid drives the FMU's co-simulation interface (else model exchange)."""
        return self.interface == CO_SIMULATION

    @property
    def can_interpolate_inputs(self) -> bool:
        """Whether the FMU accepts first-order input derivatives (FMI 2.0 co-simulation)."""
        cs = self.model_description.coSimulation
        return self.is_cosimulation and self.fmi_version == "2.0" and bool(cs.canInterpolateInputs)

    @property
    def kind_label(self) -> str:
        """E.g. ``FMI 3.0 model exchange``."""
        name = "co-simulation" if self.is_cosimulation else "model exchange"
        return f"FMI {self.fmi_version} {name}"

    def usage_problems(
        self,
        free: Iterable[str],
        fixed: Mapping[str, float | bool | str],
        inputs: Iterable[str],
        outputs: Iterable[str],
    ) -> list[str]:
        """Variables whose FMI type does not fit the role a study gives them.

        Free parameters must be Real/Float; fixed values must suit their parameter's type
        (text for a String, 0/1 for a Boolean, a whole number for an Integer or Enumeration);
        inputs and outputs must be numeric scalars (Real/Float, Integer, Enumeration, Boolean).
        Names the FMU does not have are left to the caller.

        Returns
        -------
        list of str
            One message per problem, each naming the field, the variable and its type.

        """
        problems = []
        roles = (
            ("parameters", free, self.parameters, ("float",)),
            ("inputs", inputs, self.inputs, USABLE["input"]),
            ("outputs", outputs, self.outputs, USABLE["output"]),
        )
        for field, names, table, kinds in roles:
            for name in names:
                v = table.get(name)
                if v is not None and v.kind not in kinds:
                    problems.append(
                        f"{field}.{name}: '{name}' is {_article(v.type_label)} "
                        f"{v.causality}, which fmuid cannot use there ({_ROLE_HELP[field]})"
                    )
        for name, value in fixed.items():
            if (v := self.parameters.get(name)) is None:
                continue
            number = not isinstance(value, str | bool)
            fits = {
                "string": isinstance(value, str),
                "float": number,
                "integer": number and float(value).is_integer(),
                "boolean": not isinstance(value, str) and value in (0, 1),
            }.get(v.kind, False)
            if not fits:
                problems.append(
                    f"fixed.{name}: '{name}' is {_article(v.type_label)} parameter; "
                    f"{value!r} does not fit ({_FIXED_HELP.get(v.kind, 'it cannot be set')})"
                )
        return problems

    def __repr__(self) -> str:
        """Name, file and checksum prefix."""
        return f"FmuModel({self.model_name!r}, path={str(self.path)!r}, sha256={self.sha256[:12]})"


def _article(word: str) -> str:
    return ("an " if word[0].upper() in "AEIOU" else "a ") + word


def _choose_interface(path: Path, available: tuple[str, ...], wanted: str | None) -> str:
    if wanted not in INTERFACES:
        raise FmuError(
            f"unknown FMI interface {wanted!r}: use one of "
            + ", ".join(repr(k) for k in INTERFACES if k is not None)
        )
    if not available:
        raise FmuError(
            f"{path}: the FMU has neither a co-simulation nor a model-exchange interface "
            "(scheduled execution is not supported)"
        )
    chosen = INTERFACES[wanted]
    if chosen is None:
        return available[0]
    if chosen not in available:
        raise FmuError(
            f"{path}: the FMU has no {SPEC_NAMES[chosen]} interface "
            f'(it has {SPEC_NAMES[available[0]]}); use interface "auto" or '
            f'"{SPEC_NAMES[available[0]]}"'
        )
    return chosen
