"""Files written by the package are complete or absent: each is written
under a temporary name beside its destination, then renamed."""

import contextlib
import json
import os
import uuid
from collections.abc import Iterator


@contextlib.contextmanager
def atomic_path(path: str) -> Iterator[str]:
    """Yields a temporary path beside `path`; renames it to `path` only if the
    block finishes, so readers never see a half-written file."""
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    suffix = os.path.splitext(path)[1]
    tmp = os.path.join(directory, f".tmp-{uuid.uuid4().hex}{suffix}")
    # Created here with the usual mode (0666 less the umask), exclusively.
    os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_text(path: str, text: str) -> None:
    with atomic_path(path) as tmp, open(tmp, "w") as f:
        f.write(text)


def write_json(path: str, obj) -> None:
    write_text(path, json.dumps(obj, indent=2) + "\n")


def write_section(path: str, name: str, text: str) -> None:
    """Replaces what lies between the lines `<!-- BEGIN name -->` and
    `<!-- END name -->` of the document at `path` with `text`, so a command
    writes its own table into a hand-written page."""
    begin, end = f"<!-- BEGIN {name} -->\n", f"<!-- END {name} -->"
    with open(path) as f:
        page = f.read()
    head, found, rest = page.partition(begin)
    _, found_end, tail = rest.partition(end)
    if not found or not found_end:
        raise ValueError(f"{path}: no section {name!r} ({begin.strip()} … {end})")
    write_text(path, head + begin + text.rstrip("\n") + "\n" + end + tail)
