"""The demo files embedded in the library (what ``cablesense demo list`` shows):
scenes, recordings and the thesis tables, usable without the repository.

    import cablesense.demo
    scene = cablesense.demo.scene("scenes/ftdcr_v4.toml")
    # the same as cablesense.Scene.from_file("demo:scenes/ftdcr_v4.toml")
    lines = cablesense.demo.text("hardware/ftdcr_v4/val.csv").splitlines()
"""

from typing import List, Tuple

from ._cablesense import Scene, demo_files, demo_text

PREFIX = "demo:"


def files() -> List[Tuple[str, str]]:
    """Every embedded file as (name, what it is for)."""
    return list(demo_files())


def names() -> List[str]:
    """The names of the embedded files (paths relative to the repository's data/)."""
    return [name for name, _ in demo_files()]


def text(name: str) -> str:
    """The text of an embedded file (``name`` with or without ``demo:``); KeyError
    if there is none."""
    return str(demo_text(name))


def scene(name: str) -> Scene:
    """An embedded scene, validated (``name`` with or without ``demo:``)."""
    if not name.startswith(PREFIX):
        name = PREFIX + name
    return Scene.from_file(name)


__all__ = ["PREFIX", "files", "names", "scene", "text"]
