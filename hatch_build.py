"""The build hook of enctools' wheel (and of ``pip install -e .``): the optional kernel.

Compiles ``enctools/_kernel.c`` into ``enctools/_enckernel.so`` (enctools/kernel_build.py
says how) and ships it in the wheel, which is then tagged for this platform. When it
cannot be compiled the install goes on without it, and enctools runs its numpy passes.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

from hatchling.builders.hooks.plugin.interface import BuildHookInterface
from packaging.tags import sys_tags


class KernelBuildHook(BuildHookInterface):  # type: ignore[misc]
    PLUGIN_NAME = "custom"

    def initialize(self, version: str, build_data: dict[str, Any]) -> None:
        if self.target_name != "wheel":
            return
        root = Path(self.root)
        spec = importlib.util.spec_from_file_location(
            "enctools_kernel_build", root / "enctools" / "kernel_build.py")
        assert spec is not None and spec.loader is not None
        how = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(how)
        out = root / "enctools" / "_enckernel.so"
        ok, seconds, message = how.build(root / "enctools" / "_kernel.c", out)
        if not ok:
            out.unlink(missing_ok=True)   # an older build would not match this source
            print(f"enctools: the compiled kernel was not built ({message.splitlines()[-1:]}); "
                  "the numpy passes will run", file=sys.stderr)
            return
        print(f"enctools: compiled kernel built in {seconds:.2f} s", file=sys.stderr)
        build_data["artifacts"].append("enctools/_enckernel.so")
        build_data["pure_python"] = False
        # C over buffers through ctypes: any Python 3 of this platform loads it
        build_data["tag"] = f"py3-none-{next(iter(sys_tags())).platform}"
