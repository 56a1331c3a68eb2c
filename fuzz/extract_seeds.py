#!/usr/bin/env python3
"""Writes the fuzzers' seed corpora: every bundled netlist and scene, every multi-line string
literal of the Rust sources and tests (the inputs the test suite feeds the readers), the fenced
`toml` blocks of the docs, and the kept regression inputs.

Usage: extract_seeds.py OUT_DIR   (writes OUT_DIR/netlist/* and OUT_DIR/scene/*)
"""

import hashlib
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

# A Rust string literal: raw (r"..", r#".."#, ...) or ordinary with escapes.
LITERAL = re.compile(r'r(#*)"(.*?)"\1|"((?:[^"\\]|\\.)*)"', re.S)
ESCAPES = {"n": "\n", "t": "\t", "r": "\r", "0": "\0", "\\": "\\", '"': '"', "'": "'"}


def unescape(body: str) -> str:
    out, i = [], 0
    while i < len(body):
        c = body[i]
        if c != "\\":
            out.append(c)
            i += 1
            continue
        nxt = body[i + 1] if i + 1 < len(body) else ""
        if nxt == "\n":  # line continuation: skip the newline and leading blanks
            i += 2
            while i < len(body) and body[i] in " \t":
                i += 1
        elif nxt == "u" and body[i + 2 : i + 3] == "{":
            end = body.index("}", i)
            out.append(chr(int(body[i + 3 : end], 16)))
            i = end + 1
        elif nxt == "x":
            out.append(chr(int(body[i + 2 : i + 4], 16)))
            i += 4
        else:
            out.append(ESCAPES.get(nxt, nxt))
            i += 2
    return "".join(out)


def is_scene(text: str) -> bool:
    return any(k in text for k in ("[simulation]", "[[part]]", "[[connection]]", "[record]"))


def main() -> None:
    out = pathlib.Path(sys.argv[1])
    seeds = {"netlist": set(), "scene": set()}
    for ext in ("cir", "sp", "net"):
        for f in ROOT.glob(f"examples/**/*.{ext}"):
            seeds["netlist"].add(f.read_text())
    for f in ROOT.glob("examples/**/*.toml"):
        seeds["scene"].add(f.read_text())
    for f in list(ROOT.glob("crates/*/tests/*.rs")) + list(ROOT.glob("crates/*/src/**/*.rs")):
        for m in LITERAL.finditer(f.read_text()):
            text = m.group(2) if m.group(2) is not None else unescape(m.group(3))
            if "\n" not in text.strip("\n") or len(text) < 8:
                continue
            seeds["scene" if is_scene(text) else "netlist"].add(text)
    for f in list(ROOT.glob("docs/*.md")) + [ROOT / "README.md"]:
        for block in re.findall(r"```toml\n(.*?)```", f.read_text(), re.S):
            seeds["scene"].add(block)
    for kind in seeds:
        for f in (ROOT / "fuzz/regressions" / kind).glob("*"):
            seeds[kind].add(f.read_bytes())
    for kind, texts in seeds.items():
        d = out / kind
        d.mkdir(parents=True, exist_ok=True)
        for text in texts:
            data = text if isinstance(text, bytes) else text.encode()
            (d / hashlib.sha1(data).hexdigest()[:16]).write_bytes(data)
        print(f"{kind}: {len(texts)} seeds", file=sys.stderr)


if __name__ == "__main__":
    main()
