"""``python -m stagger_nb.app NOTEBOOK``: a notebook as a web page (Voilà), with nothing asked of the network.

    python -m stagger_nb.app notebooks/00_quickstart.ipynb [--port 8866] [voila options...]

Voilà (``pip install voila``, in the ``notebooks`` extra) runs the notebook and shows its outputs and widgets
(the editors, the 3D view, the plots) without the code. Two things of a plain ``voila NOTEBOOK`` are changed:

- the page template is ``stagger_nb`` (``stagger_nb/share/voila/templates/stagger_nb``, found through
  ``JUPYTER_PATH``): Voilà's "lab" page without its two stylesheet links to a CDN (Font Awesome, which Voilà's
  own bundle already carries), so an offline machine loads everything from the local server;
- the JupyterLab extension ``jupyterlab-jupytext`` is not loaded: it is a JupyterLab document plugin and
  Voilà has no document manager to give it (a module-federation error for ``@jupyterlab/docmanager``). The
  ``voila.json`` files at the repository root and in ``notebooks/`` say the same to a plain ``voila``.

:func:`voila_command` gives the command line and environment (the browser test starts Voilà with it).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

__all__ = ["voila_command", "TEMPLATE", "SHARE", "EXTENSION_DENYLIST", "main"]

TEMPLATE = "stagger_nb"
SHARE = Path(__file__).resolve().parent / "share"      # a Jupyter data folder: voila/templates/stagger_nb
EXTENSION_DENYLIST = ("jupyterlab-jupytext",)


def voila_command(notebook, port: int | None = None, ip: str = "127.0.0.1", extra=(), env=None
                  ) -> tuple[list[str], dict]:
    """``(argv, env)`` that serve ``notebook`` with Voilà on ``ip:port`` (default port: Voilà's 8866) with the
    ``stagger_nb`` template and :data:`EXTENSION_DENYLIST`; ``extra``: more Voilà options; ``env``: the
    environment to extend (default ``os.environ``)."""
    env = dict(os.environ if env is None else env)
    env["JUPYTER_PATH"] = os.pathsep.join([str(SHARE)] + [p for p in env.get("JUPYTER_PATH", "").split(os.pathsep)
                                                           if p])
    argv = [sys.executable, "-m", "voila", str(notebook), "--no-browser", f"--template={TEMPLATE}",
            f"--Voila.ip={ip}"]
    if port is not None:
        argv.append(f"--port={int(port)}")
    argv += [f"--VoilaConfiguration.extension_denylist={name}" for name in EXTENSION_DENYLIST]
    return argv + [str(a) for a in extra], env


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m stagger_nb.app", description=__doc__.splitlines()[0])
    parser.add_argument("notebook", help="the .ipynb file to show")
    parser.add_argument("--port", type=int, default=None, help="port (default: Voilà's 8866)")
    parser.add_argument("--ip", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    args, extra = parser.parse_known_args(argv)
    if not Path(args.notebook).is_file():
        parser.error(f"notebook: {args.notebook} is not a file")
    try:
        import voila  # noqa: F401
    except ImportError:
        print("voila is not installed: pip install voila (or the 'notebooks' extra: pip install -e '.[notebooks]')",
              file=sys.stderr)
        return 2
    cmd, env = voila_command(args.notebook, args.port, args.ip, extra)
    return subprocess.call(cmd, env=env)


if __name__ == "__main__":
    sys.exit(main())
