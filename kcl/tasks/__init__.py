"""The task library of the KCL, one task per module; see :mod:`kcl.tasks.base`.

Importing this package imports every task module in it, and defining a task
class registers it: :data:`TASK_TYPES` maps the ``type:`` names of the actions
YAML to the classes. A new task is one new module here (``docs/architecture.md``).
"""

from __future__ import annotations

import importlib
import pkgutil

from kcl.tasks.base import TASK_REGISTRY, Param, Targets, Task, TaskContext, TaskOutput

#: modules of this package that hold no task
_SUPPORT_MODULES = frozenset({"base", "batch", "jit"})

for _module in sorted(m.name for m in pkgutil.iter_modules(__path__)):
    if _module not in _SUPPORT_MODULES:
        importlib.import_module(f"{__name__}.{_module}")

#: YAML ``type:`` name -> task class, in a fixed order (sorted by name)
TASK_TYPES: dict[str, type[Task]] = dict(sorted(TASK_REGISTRY.items()))

__all__ = ["TASK_TYPES", "Param", "Targets", "Task", "TaskContext", "TaskOutput"]
