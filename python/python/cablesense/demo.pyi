"""The demo files embedded in the library (see demo.py)."""

from typing import List, Tuple

from . import Scene

PREFIX: str

__all__ = ["PREFIX", "files", "names", "scene", "text"]

def files() -> List[Tuple[str, str]]: ...
def names() -> List[str]: ...
def text(name: str) -> str: ...
def scene(name: str) -> Scene: ...
