"""Package namespaces that import their modules on first use.

A package's ``__init__`` lists what it exports and from which of its modules; a name is imported
when it is first looked up (PEP 562), so ``import armpath.geometry.primitives`` or ``armpath
--help`` no longer pays for every module of every package on the way. Type checkers read the
same names from the package's ``if TYPE_CHECKING:`` imports.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any


def lazy_exports(
    package: str, exports: dict[str, tuple[str, ...]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package`` whose ``exports`` map each of its modules
    (relative name) to the names it exports; a name's value is cached in the package once
    looked up.

    A name that is also the name of its module (``model.seed_arm``) is bound at once: importing
    a submodule sets the package attribute of that name to the module, which would otherwise
    hide the function behind it."""
    home = {name: module for module, names in exports.items() for name in names}
    namespace = importlib.import_module(package).__dict__
    for module, names in exports.items():
        if module in names:
            namespace[module] = getattr(importlib.import_module(f"{package}.{module}"), module)

    def attribute(name: str) -> Any:
        module = home.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    def listing() -> list[str]:
        return sorted(set(namespace) | set(home))

    return attribute, listing


__all__ = ["lazy_exports"]
