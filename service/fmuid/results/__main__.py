"""Print the JSON Schema of result kinds: ``python -m fmuid.results [KIND ...]`` (all when none).

One kind prints its schema; several (or none named) print ``{kind: schema}``. Exit status 2
for an unknown kind.
"""

from __future__ import annotations

import json
import sys

from fmuid.results.schema import KINDS, json_schema


def main(argv: list[str]) -> int:
    """Write the schemas of the kinds named in ``argv`` to stdout; return the exit status."""
    kinds = argv or list(KINDS)
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        sys.stderr.write(f"unknown result kind {unknown[0]!r}; the kinds: {', '.join(KINDS)}\n")
        return 2
    schemas = {k: json_schema(k) for k in kinds}
    sys.stdout.write(json.dumps(schemas[kinds[0]] if len(argv) == 1 else schemas, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
