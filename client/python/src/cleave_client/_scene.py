"""A scene as the server takes it: text and its format, from a path, TOML or
JSON text, or a dict."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any, Union

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from ._proto import cleave_pb2 as pb

SceneLike = Union[str, os.PathLike, dict]


def scene_text(scene: SceneLike) -> tuple[str, int]:
    """(text, SceneFormat) of a scene given as a path (``.toml`` or
    ``.json``), as TOML or JSON text, or as a dict (sent as JSON).

    A string is a path when it names an existing file or ends in ``.toml``
    or ``.json`` without newlines; otherwise it is the scene's text, whose
    format the server sniffs (JSON when it starts with ``{``).
    """
    if isinstance(scene, dict):
        return json.dumps(scene), pb.SCENE_FORMAT_JSON
    if isinstance(scene, os.PathLike) or (
        isinstance(scene, str)
        and "\n" not in scene
        and (scene.endswith((".toml", ".json")) or Path(scene).is_file())
    ):
        path = Path(scene)
        text = path.read_text(encoding="utf-8")
        fmt = pb.SCENE_FORMAT_JSON if path.suffix == ".json" else pb.SCENE_FORMAT_TOML
        return text, fmt
    if isinstance(scene, str):
        return scene, pb.SCENE_FORMAT_UNSPECIFIED
    raise TypeError(f"scene: expected a path, TOML/JSON text or a dict, got {type(scene).__name__}")


def scene_document(scene: SceneLike) -> dict[str, Any]:
    """The scene as a dict (a TOML scene parsed), for a study to edit."""
    if isinstance(scene, dict):
        return json.loads(json.dumps(scene))  # a deep copy of plain values
    text, fmt = scene_text(scene)
    if fmt == pb.SCENE_FORMAT_JSON or (
        fmt == pb.SCENE_FORMAT_UNSPECIFIED and text.lstrip().startswith("{")
    ):
        return json.loads(text)
    return tomllib.loads(text)
