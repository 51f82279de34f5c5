"""Builds the optional C accelerator of the BVH reader (stagger_nb/io/_cparse.c); every other piece of
metadata lives in pyproject.toml. ``optional=True``: where no compiler is found the package installs
without it and ``read_bvh`` parses with numpy and pyarrow, with identical results."""
from setuptools import Extension, setup

setup(ext_modules=[Extension("stagger_nb.io._cparse", ["stagger_nb/io/_cparse.c"], optional=True,
                             extra_compile_args=["-O2", "-fno-fast-math", "-ffp-contract=off"])])
