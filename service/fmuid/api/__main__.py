"""``python -m fmuid.api [--host H] [--port P]``: run the service (same as ``fmuid serve``)."""

from __future__ import annotations

import argparse
import logging

from fmuid.api import serve

if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m fmuid.api")
    parser.add_argument("--host", default=None)
    parser.add_argument("--port", type=int, default=None)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s %(message)s")
    serve(args.host, args.port)
