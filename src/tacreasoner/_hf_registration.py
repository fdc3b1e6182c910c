"""Teach ``transformers``' Auto classes about TacReasoner as soon as ``import tacreasoner`` has run.

Importing torch and transformers costs seconds, and most ``tacreasoner`` commands never need them,
so ``import tacreasoner`` does not import them. Instead it installs a one-shot import hook: when
transformers' ``configuration_auto``, ``modeling_auto`` or ``processing_auto`` module finishes
loading (whoever imports it), the TacReasoner config, model and processor are registered with it.
The model and processor are registered as light stand-ins that import the real classes on first
use, so registration never imports modelling code while transformers is half-initialised.
If those modules are already loaded, registration happens at once.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys
from types import ModuleType
from typing import Any

__all__ = ["install", "register_loaded"]

_CONFIG, _MODEL, _PROCESSOR = (f"transformers.models.auto.{m}" for m in
                               ("configuration_auto", "modeling_auto", "processing_auto"))


def _config_class() -> type | None:
    """The config class, or None while its own module is being imported (it registers itself at its end)."""
    module = sys.modules.get("tacreasoner.model.configuration")
    if module is not None:
        return getattr(module, "TacReasonerConfig", None)
    from tacreasoner.model.configuration import TacReasonerConfig

    return TacReasonerConfig


class TacReasonerForCausalLM:
    """Stands in for :class:`tacreasoner.model.modeling.TacReasonerForCausalLM` in the Auto mapping."""

    @staticmethod
    def real() -> Any:
        from tacreasoner.model import modeling

        return modeling.TacReasonerForCausalLM

    @classmethod
    def from_pretrained(cls, *args: Any, **kwargs: Any) -> Any:
        kwargs.pop("trust_remote_code", None)
        return cls.real().from_pretrained(*args, **kwargs)

    @classmethod
    def _from_config(cls, config: Any, **kwargs: Any) -> Any:
        kwargs.pop("trust_remote_code", None)
        return cls.real()._from_config(config, **kwargs)


class TacReasonerProcessor:
    """Stands in for :class:`tacreasoner.model.processing.TacReasonerProcessor` (found by this class name)."""

    @classmethod
    def from_pretrained(cls, directory: Any, **kwargs: Any) -> Any:
        from tacreasoner.model import processing

        return processing.TacReasonerProcessor.from_pretrained(directory)


def _register(name: str, module: ModuleType) -> None:
    config = _config_class()
    if config is None:
        return
    if name == _CONFIG:
        module.AutoConfig.register(config.model_type, config, exist_ok=True)
    elif name == _MODEL:
        TacReasonerForCausalLM.config_class = config
        module.AutoModelForCausalLM.register(config, TacReasonerForCausalLM, exist_ok=True)
    elif name == _PROCESSOR:
        module.AutoProcessor.register(config, TacReasonerProcessor, exist_ok=True)


class _AfterImport(importlib.abc.MetaPathFinder):
    def __init__(self) -> None:
        self.pending = {_CONFIG, _MODEL, _PROCESSOR}

    def find_spec(self, fullname: str, path: Any, target: Any = None) -> Any:
        if fullname not in self.pending:
            return None
        self.pending.discard(fullname)
        if not self.pending and self in sys.meta_path:
            sys.meta_path.remove(self)
        spec = _find_without(self, fullname, path, target)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        loader, original = spec.loader, spec.loader.exec_module

        def exec_module(module: ModuleType) -> None:
            original(module)
            _register(fullname, module)

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


def _find_without(finder: _AfterImport, fullname: str, path: Any, target: Any) -> Any:
    for other in sys.meta_path:
        if other is finder or not hasattr(other, "find_spec"):
            continue
        spec = other.find_spec(fullname, path, target)
        if spec is not None:
            return spec
    return None


def register_loaded() -> None:
    """Register with every Auto module that is already loaded (called by the config module once defined)."""
    for name in (_CONFIG, _MODEL, _PROCESSOR):
        module = sys.modules.get(name)
        if module is not None and hasattr(module, "__file__") and _fully_loaded(module):
            _register(name, module)


def _fully_loaded(module: ModuleType) -> bool:
    spec = getattr(module, "__spec__", None)
    return not getattr(spec, "_initializing", False)


def install() -> None:
    """Register now for modules already loaded; hook the rest. Does nothing without transformers."""
    try:
        if importlib.util.find_spec("transformers") is None:
            return
    except (ImportError, ValueError):
        return
    hook = _AfterImport()
    for name in list(hook.pending):
        if name in sys.modules:
            hook.pending.discard(name)
    register_loaded()
    if hook.pending:
        sys.meta_path.insert(0, hook)
