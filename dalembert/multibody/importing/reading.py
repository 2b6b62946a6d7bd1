"""Reading a model file with MuJoCo's ``MjSpec``, its errors made clear.

MuJoCo parses both formats (MJCF and URDF) and compiles them: its compiled model
holds every number dalembert needs in SI units and radians, with the defaults
classes applied and the inertials of bodies without an ``<inertial>`` computed from
their geoms. A file MuJoCo cannot read gives a :class:`~dalembert.ModelFileError`
naming the file and passing MuJoCo's own message on.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ...errors import ModelFileError

#: The extra that installs MuJoCo (the parser and compiler of the model files).
INSTALL = "pip install 'dalembert[import]'"


def mujoco_module() -> Any:
    """``mujoco``, imported on first use (an optional dependency)."""
    try:
        import mujoco
    except ImportError as exc:
        raise ModelFileError(f"importing a model file needs MuJoCo ({INSTALL})") from exc
    return mujoco


def is_xml_text(source: str | os.PathLike[str]) -> bool:
    """Whether ``source`` is the XML itself rather than a path to it."""
    return isinstance(source, str) and source.lstrip().startswith("<")


def compile_model(source: str | os.PathLike[str], kind: str) -> tuple[Any, Any, str]:
    """``(spec, model, label)``: the parsed spec, MuJoCo's compiled model and a label
    naming the source in messages (the path, or "the MJCF string").

    Parameters
    ----------
    source
        A path, or (MJCF) the XML text.
    kind
        ``"MJCF"`` or ``"URDF"``, for the messages.

    Examples
    --------
    >>> spec, model, label = compile_model("<mujoco/>", "MJCF")
    >>> model.nbody, label
    (1, 'the MJCF string')
    >>> compile_model("<mujoco><bogus/></mujoco>", "MJCF")
    Traceback (most recent call last):
    ...
    dalembert.errors.ModelFileError: cannot read the MJCF string: MuJoCo says: ...
    """
    mujoco = mujoco_module()
    if is_xml_text(source):
        label = f"the {kind} string"
        read = lambda: mujoco.MjSpec.from_string(str(source))  # noqa: E731
    else:
        path = Path(source)
        label = f"{kind} file {str(path)!r}"
        if not path.is_file():
            raise ModelFileError(f"cannot read {label}: no such file")
        read = lambda: mujoco.MjSpec.from_file(str(path))  # noqa: E731
    try:
        spec = read()
    except Exception as exc:  # MuJoCo's parse errors are ValueErrors with its message
        raise ModelFileError(f"cannot read {label}: MuJoCo says: {_message(exc)}") from None
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelFileError(f"cannot compile {label}: MuJoCo says: {_message(exc)}") from None
    return spec, model, label


def _message(exc: Exception) -> str:
    """MuJoCo's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__
