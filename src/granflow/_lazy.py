"""Public names that resolve on first use (PEP 562), so that ``import granflow`` stays light.

Each package lists which of its modules defines which public name; the module is imported
the first time the name is looked up, and the name is then cached on the package. This is
the pattern of SciPy and scikit-image (``lazy_loader``), in a few lines.
"""

import importlib
import sys


def attach(package, names_by_module):
    """``(__getattr__, __dir__, __all__)`` for ``package``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    names_by_module : dict of str to list of str
        Module path relative to the package (``"friction"``, ``"..model"`` is not allowed;
        use a dotted absolute path starting with ``granflow.`` for names from elsewhere)
        mapped to the public names it defines.
    """
    where = {}
    for module, names in names_by_module.items():
        target = module if module.startswith("granflow.") else f"{package}.{module}"
        for name in names:
            where[name] = target

    def __getattr__(name):  # noqa: N807 (PEP 562)
        target = where.get(name)
        if target is None:
            # only a package has submodules; asking a plain module (granflow.rsf) for one
            # would make importlib ask it for __path__ again, without end
            if "__path__" in vars(sys.modules[package]):
                try:
                    return importlib.import_module(f"{package}.{name}")
                except ModuleNotFoundError as exc:
                    if exc.name != f"{package}.{name}":
                        raise
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(target), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():  # noqa: N807 (PEP 562)
        return sorted(set(where) | set(vars(sys.modules[package])))

    return __getattr__, __dir__, sorted(where)
