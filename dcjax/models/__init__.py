"""Motor and drive models behind one protocol (`Model`); `get_model` resolves a built-in name
(`"dc"`, the paper's model and the default, `"dc-coulomb"`, `"pmsm"` or `"servo"`), a `package.module:attr` path or a
`path/to/file.py:attr`."""

import hashlib
import importlib
import importlib.util
import sys
from pathlib import Path

from ..errors import ModelError
from .base import DiscreteModel, Model
from .dc import DC, DCCoulomb
from .pmsm import PMSM
from .servo import Servo
from .trig import cos, sin

MODELS: dict[str, type[Model]] = {"dc": DC, "dc-coulomb": DCCoulomb, "pmsm": PMSM, "servo": Servo}


def get_model(model: "str | Model | type[Model] | None" = None) -> Model:
    """`None` -> `DC()`; a `Model` instance as is; a `Model` subclass instantiated; a built-in name;
    or `"package.module:attr"` naming a `Model` instance, subclass or a function returning one."""
    if model is None:
        return DC()
    if isinstance(model, Model):
        return model
    if isinstance(model, type) and issubclass(model, Model):
        return model()
    if not isinstance(model, str):
        raise ModelError(f"model must be a name {sorted(MODELS)}, 'package.module:attr' or a dcjax Model, got {model!r}")
    if model.lower() in MODELS:
        return MODELS[model.lower()]()
    if ":" not in model and model.endswith(".py"):
        return _defined_model(model)
    if ":" not in model:
        raise ModelError(f"unknown model {model!r}; built-in models are {sorted(MODELS)}, or give 'package.module:attr' or 'file.py'")
    mod_name, _, attr = model.rpartition(":")
    try:
        module = _import_file(mod_name) if mod_name.endswith(".py") else importlib.import_module(mod_name)
        obj = getattr(module, attr)
    except (ImportError, AttributeError, SyntaxError) as e:
        raise ModelError(f"cannot import model {model!r}: {e}") from None
    if callable(obj) and not isinstance(obj, Model) and not (isinstance(obj, type) and issubclass(obj, Model)):
        obj = obj()
    if isinstance(obj, type) and issubclass(obj, Model):
        obj = obj()
    if not isinstance(obj, Model):
        raise ModelError(f"{model!r} is not a dcjax Model (got {type(obj).__name__})")
    return obj


def _defined_model(path: str) -> Model:
    """The one `Model` subclass a `.py` file defines (not one it imports)."""
    try:
        module = _import_file(path)
    except (ImportError, SyntaxError) as e:
        raise ModelError(f"cannot import model {path!r}: {e}") from None
    found = [
        obj
        for obj in vars(module).values()
        if isinstance(obj, type)
        and issubclass(obj, Model)
        and obj.__module__ == module.__name__
        and not getattr(obj, "__abstractmethods__", None)
    ]
    if len(found) != 1:
        what = "no dcjax Model subclass" if not found else f"{len(found)} Model subclasses ({', '.join(c.__name__ for c in found)})"
        raise ModelError(f"{path} defines {what}: give the model as '{path}:NAME'")
    return found[0]()


FILE_MODULE_PREFIX = "dcjax_model_file_"


def _import_file(path: str):
    """The module defined by a `.py` file, imported once per file (under a name derived from its
    absolute path, so `model_spec` can name the file again). While it loads, its own folder is
    importable (`from pmsm import PMSM` of a `pmsm.py` beside it), and only then."""
    file = Path(path).expanduser().resolve()
    if not file.is_file():
        raise ImportError(f"no such file: {path}")
    name = FILE_MODULE_PREFIX + hashlib.sha1(str(file).encode()).hexdigest()[:12]
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, file)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path} as a Python module")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    folder = str(file.parent)
    added = folder not in sys.path
    if added:
        sys.path.insert(0, folder)
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    finally:
        if added and folder in sys.path:
            sys.path.remove(folder)
    return module


def model_spec(model: Model) -> str:
    """A string `get_model` resolves back: a built-in name, `module:Class` or `file.py:Class` (of
    the class a `Model.measuring` variant was made from: the observation records its channels)."""
    cls = type(model).measuring_base or type(model)
    if cls is MODELS.get(model.name):
        return model.name
    module = cls.__module__
    if module.startswith(FILE_MODULE_PREFIX):
        return f"{sys.modules[module].__file__}:{cls.__qualname__}"
    return f"{module}:{cls.__qualname__}"


__all__ = ["DC", "DCCoulomb", "MODELS", "PMSM", "DiscreteModel", "Model", "Servo", "cos", "get_model", "model_spec", "sin"]
