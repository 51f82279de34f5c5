"""Builds the optional C accelerators: the BVH reader's (stagger_nb/io/_cparse.c), evaluate()'s spline
kernel (stagger_nb/staggered/_cspline.c) and guided warping's DP (stagger_nb/timewarp/_cdp.c, at -O3: its
loops vectorised); every other piece of metadata lives in pyproject.toml. ``optional=True``: where no compiler is
found the package installs without them and ``read_bvh`` / ``staggered.evaluate`` / ``timewarp.dp.constrained_dp``
run their numpy paths, with identical results."""
from setuptools import Extension, setup

_FLAGS = ["-O2", "-fno-fast-math", "-ffp-contract=off"]   # IEEE arithmetic as written: the numpy paths' bits

setup(ext_modules=[Extension("stagger_nb.io._cparse", ["stagger_nb/io/_cparse.c"], optional=True,
                             depends=["stagger_nb/_carray.h"],
                             extra_compile_args=_FLAGS),
                   Extension("stagger_nb.staggered._cspline", ["stagger_nb/staggered/_cspline.c"], optional=True,
                             depends=["stagger_nb/_carray.h"],
                             extra_compile_args=_FLAGS),
                   Extension("stagger_nb.timewarp._cdp", ["stagger_nb/timewarp/_cdp.c"], optional=True,
                             depends=["stagger_nb/_carray.h"],
                             extra_compile_args=_FLAGS + ["-O3"])])
