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
        path = _path(source, kind)
        label = f"{kind} file {str(path)!r}"
        read = lambda: mujoco.MjSpec.from_file(str(path))  # noqa: E731
    try:
        spec = read()
    except Exception as exc:  # MuJoCo's parse errors are ValueErrors with its message
        raise ModelFileError(f"cannot read {label}: MuJoCo says: {_message(exc)}") from None
    if not is_xml_text(source):
        resolve_packages(spec, Path(source))
    try:
        model = spec.compile()
    except Exception as exc:
        raise ModelFileError(f"cannot compile {label}: MuJoCo says: {_message(exc)}") from None
    return spec, model, label


def _path(source: object, kind: str) -> Path:
    """The model file ``source`` names, checked to be one (a clear error for anything else:
    not a path, an empty name, a folder, a FIFO, which MuJoCo would wait on forever)."""
    what = "a path to the file" + (" or the XML text" if kind == "MJCF" else "")
    if isinstance(source, bytes):
        raise ModelFileError(f"the {kind} source is bytes: give {what} as a str "
                             "(e.g. data.decode())")
    try:
        path = Path(source)  # type: ignore[arg-type]
    except TypeError:
        raise ModelFileError(f"the {kind} source must be {what}, got {source!r:.80} "
                             f"({type(source).__name__})") from None
    if not str(source).strip():
        raise ModelFileError(f"the {kind} source is an empty string: give {what}")
    label = f"{kind} file {str(path)!r}"
    if path.is_dir():
        raise ModelFileError(f"cannot read {label}: it is a folder, not a file")
    if path.exists() and not path.is_file():
        raise ModelFileError(f"cannot read {label}: it is not a regular file (a FIFO, a "
                             "device or a socket)")
    if not path.is_file():
        raise ModelFileError(f"cannot read {label}: no such file")
    return path


def resolve_packages(spec: Any, path: Path) -> None:
    """Point the ``package://NAME/...`` mesh files of a ROS description at the folder
    ``NAME`` found above the file (as ROS would, for a package laid out in one tree);
    MuJoCo does not resolve them. A mesh not found that way is left as it is (MuJoCo's
    error then names it).

    Parameters
    ----------
    spec
        The parsed ``MjSpec`` (its meshes are changed in place).
    path
        The model file.

    Examples
    --------
    >>> import mujoco, tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     mesh = Path(folder, "my_robot", "meshes", "link.stl")
    ...     mesh.parent.mkdir(parents=True)
    ...     _ = mesh.write_text("")
    ...     spec = mujoco.MjSpec()
    ...     _ = spec.add_mesh(file="package://my_robot/meshes/link.stl")
    ...     resolve_packages(spec, Path(folder, "my_robot", "urdf", "robot.urdf"))
    ...     Path(spec.meshes[0].file).relative_to(folder).as_posix()
    'my_robot/meshes/link.stl'
    """
    prefix = "package://"
    for mesh in spec.meshes:
        if not mesh.file.startswith(prefix):
            continue
        package, _, rest = mesh.file[len(prefix):].partition("/")
        for folder in path.resolve().parents:
            candidates = [folder / package / rest, *([folder / rest] * (folder.name == package))]
            found = next((c for c in candidates if c.is_file()), None)
            if found is not None:
                mesh.file = str(found)
                break


def _message(exc: Exception) -> str:
    """MuJoCo's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__
