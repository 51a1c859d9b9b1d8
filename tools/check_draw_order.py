#!/usr/bin/env python3
"""Finds random draws whose order the compiler chooses.

    tools/check_draw_order.py [SOURCE_ROOT]

C++ leaves the order of evaluation of a function's arguments and of the operands of most operators
unspecified: `Eigen::Vector2d(rng.normal(), rng.normal())` or `a * rng.uniform() + b * rng.uniform()`
draw in GCC's order in a GCC build and possibly in another in a clang build, so that sample i of a
dataset, the built-in model or a trained model would depend on the compiler. This check lists every
expression with two draws from a random generator (a call of uniform, uniform_int, normal,
truncated_normal or next_u64, or a generator named *rng passed to a function) that are not ordered by
the language: ordered are the elements of a braced list, the declarators of one declaration, the
operands of `,` `&&` `||` `?:` `<<` and the sides of `=`. Exit status 1 when it finds one (each
printed as FILE:LINE), 0 otherwise. The library and tool sources are checked; tests/ is not (a test's
own inputs may differ between compilers without changing what it checks).
"""
import os
import re
import sys

DRAW = re.compile(r"\b\w+\s*(?:\.|->)\s*(?:uniform_int|uniform|truncated_normal|normal|next_u64)\s*\(|[(,]\s*\w*rng\b\s*(?=[,)])")
FOLDERS = ("core", "morph", "render", "synth", "train", "fit", "frontal", "profile", "recognition", "track", "report", "tools",
           "python", "bench", "examples")


def strip_comments_and_strings(text):
    text = re.sub(r"/\*.*?\*/", lambda m: re.sub(r"[^\n]", " ", m.group(0)), text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)
    return re.sub(r"'(?:\\.|[^'\\\n])'", "' '", text)


def split_top(text, separators):
    """Splits at the separators that lie outside any bracket."""
    pieces, depth, start, i = [], 0, 0, 0
    while i < len(text):
        c = text[i]
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif depth == 0:
            for sep in separators:
                if text.startswith(sep, i) and not _part_of_longer_operator(text, i, sep):
                    pieces.append(text[start:i])
                    start = i + len(sep)
                    i = start - 1
                    break
        i += 1
    pieces.append(text[start:])
    return pieces


def _part_of_longer_operator(text, i, sep):
    before = text[i - 1] if i > 0 else " "
    after = text[i + len(sep)] if i + len(sep) < len(text) else " "
    if sep == "=":
        return before in "=!<>+-*/%&|^" or after == "="
    if sep == "<<":
        return after in "=<" or before == "<"
    if sep == ":":
        return before == ":" or after == ":"
    return False


def groups(text):
    """The bracketed groups directly inside text: (opening bracket, start, end) of each inner text."""
    out, depth, start, opener = [], 0, 0, ""
    for i, c in enumerate(text):
        if c in "([{":
            if depth == 0:
                start, opener = i + 1, c
            depth += 1
        elif c in ")]}":
            depth -= 1
            if depth == 0:
                out.append((opener, start, i))
    return out


def unordered(text, sequenced_commas):
    """Whether text holds two draws in no defined order; sequenced_commas: its top-level commas order
    what they separate (a braced list, declarators, the comma operator)."""
    pieces = [text]
    for separators in ((",",) if sequenced_commas else (), ("&&", "||"), ("?", ":"), ("<<",), ("=",)):
        pieces = [p for piece in pieces for p in split_top(piece, separators)] if separators else pieces
    for piece in pieces:
        draws, outside, previous_end = 0, "", 0
        for opener, start, end in groups(piece):
            inner = piece[start:end]
            # A group that draws counts once here: the order inside it is checked on its own (a
            # braced list orders its elements, an argument list does not, `?:` draws one branch).
            draws += min(len(DRAW.findall("(" + inner + ")")), 1)
            if unordered(inner, opener == "{"):
                return True
            outside += piece[previous_end:start] + " "
            previous_end = end
        draws += len(DRAW.findall(outside + piece[previous_end:]))
        if draws >= 2:
            return True
    return False


def findings(root):
    for folder in FOLDERS:
        for directory, _, names in os.walk(os.path.join(root, folder)):
            for name in sorted(names):
                if not name.endswith((".cpp", ".h")):
                    continue
                path = os.path.join(directory, name)
                with open(path, encoding="utf-8", errors="replace") as f:
                    text = strip_comments_and_strings(f.read())
                offset = 0
                for statement in re.split(r"(?<=[;{}])", text):
                    if len(DRAW.findall(statement)) >= 2 and unordered(statement.rstrip(";{}"), True):
                        line = text.count("\n", 0, offset + len(statement) - len(statement.lstrip())) + 1
                        yield f"{os.path.relpath(path, root)}:{line}: {' '.join(statement.split())[:160]}"
                    offset += len(statement)


# Statements and whether their draws are unordered: the check checks itself before the sources.
EXAMPLES = [
    ("p = Eigen::Vector2d(rng.normal(), rng.normal());", True),
    ("x += a * rng.normal() * 0.7 + b * rng.normal() * 0.7;", True),
    ("const double h = std::clamp(0.12 + t * rng.uniform() * rng.uniform(), 0.05, 0.75);", True),
    ("y = f(sample_angle(rng, a), 2) - sample_angle(rng, b);", True),
    ("return {rng.uniform(), rng.uniform(), rng.uniform()};", False),
    ("const double dx = rng.normal(), dy = rng.normal();", False),
    ("const double beard = std::max(0.0, rng.uniform() < 0.5 ? 0.12 * rng.uniform() : 0.0);", False),
    ("m << rng.uniform(), rng.uniform();", False),
    ("v.push_back({rng.uniform(1, 8), rng.uniform(1, 8)});", False),
    ("o.centre = on_line + rng.uniform(-0.5, 1.0) * half * outward;", False),
]


def check_examples():
    for code, expected in EXAMPLES:
        if unordered(strip_comments_and_strings(code).rstrip(";"), True) != expected:
            sys.exit(f"check_draw_order.py: misjudges its own example: {code}")


def main():
    check_examples()
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    found = list(findings(root))
    for f in found:
        print(f)
    if found:
        print(f"{len(found)} expression(s) draw random numbers in an order the compiler chooses: one draw per statement",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
