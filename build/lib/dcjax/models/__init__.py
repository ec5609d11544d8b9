"""Motor and drive models behind one protocol (`Model`); `get_model` resolves a built-in name
(`"dc"`, the paper's model and the default, or `"dc-coulomb"`) or a `package.module:attr` path."""

import importlib

from .base import Model
from .dc import DC, DCCoulomb

MODELS: dict[str, type[Model]] = {"dc": DC, "dc-coulomb": DCCoulomb}


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
        raise ValueError(f"model must be a name {sorted(MODELS)}, 'package.module:attr' or a dcjax Model, got {model!r}")
    if model.lower() in MODELS:
        return MODELS[model.lower()]()
    if ":" not in model:
        raise ValueError(f"unknown model {model!r}; built-in models are {sorted(MODELS)}, or give 'package.module:attr'")
    mod_name, _, attr = model.partition(":")
    try:
        obj = getattr(importlib.import_module(mod_name), attr)
    except (ImportError, AttributeError) as e:
        raise ValueError(f"cannot import model {model!r}: {e}") from None
    if callable(obj) and not isinstance(obj, Model) and not (isinstance(obj, type) and issubclass(obj, Model)):
        obj = obj()
    if isinstance(obj, type) and issubclass(obj, Model):
        obj = obj()
    if not isinstance(obj, Model):
        raise ValueError(f"{model!r} is not a dcjax Model (got {type(obj).__name__})")
    return obj


__all__ = ["DC", "DCCoulomb", "MODELS", "Model", "get_model"]
