#!/usr/bin/python3
"""Checks README.md as a manual (run by ctest as test_docs_readme).

  1. it is under 250 lines;
  2. it starts with the two commands for a new machine: its first code block, within its
     first 12 lines, is exactly scripts/demo.sh and scripts/test.sh with their comments;
  3. every `morsegs SUBCOMMAND` in its code (spans and blocks) answers
     `morsegs SUBCOMMAND --help` with exit status 0;
  4. every `--flag` in its code belongs to the last command named before it (in reading
     order; `morsegs SUB` or `scripts/X.sh`): a subcommand's flag must be in that
     subcommand's --help output, a script's flag in the script's text (mpirun's flags are
     not checked); a heading ends the context, and a flag with no command before it must be
     in some subcommand's --help;
  5. every path it names under a top-level folder of the repository (docs/..., scripts/...,
     train/...) exists (globs and {a,b} expanded), link targets included.

Environment: MGS_SOURCE_DIR (the repository), MGS_CLI (the morsegs binary); a README path
may be given as argv[1] to check another file."""
import glob
import os
import re
import subprocess
import sys

MAX_LINES = 250
START = [
    "scripts/demo.sh     # installs packages, builds, runs `morsegs demo` on the bundled scene",
    "scripts/test.sh     # installs packages, builds, runs all tests (+ ASan/UBSan fast suite, fuzzers)",
]

errors = []


def fail(msg):
    errors.append(msg)


def code_pieces(text):
    """Code of the README in reading order: (line number, code text) for each line of a
    fenced block and each inline `span`."""
    out = []
    fenced = False
    for no, line in enumerate(text.split("\n"), 1):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced and line.startswith("#"):
            out.append((no, None))  # a heading: the command context ends
            continue
        if fenced:
            out.append((no, line))
        else:
            for m in re.finditer(r"(`+)(.+?)\1", line):
                out.append((no, m.group(2)))
    return out


def help_text(cli, sub, cache):
    if sub not in cache:
        try:
            p = subprocess.run([cli] + sub.split() + ["--help"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               timeout=120)
            cache[sub] = (p.returncode, p.stdout.decode("utf-8", "replace"))
        except (OSError, subprocess.TimeoutExpired) as e:
            cache[sub] = (-1, str(e))
    return cache[sub]


def has_flag(text, flag):
    return re.search(re.escape(flag) + r"(?![\w-])", text) is not None


def expand_braces(path):
    m = re.search(r"\{([^{}]*)\}", path)
    if not m:
        return [path]
    out = []
    for alt in m.group(1).split(","):
        out += expand_braces(path[:m.start()] + alt + path[m.end():])
    return out


def main():
    src = os.environ.get("MGS_SOURCE_DIR") or os.path.join(os.path.dirname(__file__), "..", "..")
    cli = os.environ.get("MGS_CLI")
    readme = sys.argv[1] if len(sys.argv) > 1 else os.path.join(src, "README.md")
    if not cli or not os.access(cli, os.X_OK):
        print("MGS_CLI does not name the morsegs binary: %r" % cli)
        return 1
    with open(readme, encoding="utf-8") as f:
        text = f.read()
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()

    # 1. length
    if len(lines) >= MAX_LINES:
        fail("README.md has %d lines (must be under %d)" % (len(lines), MAX_LINES))

    # 2. the two commands first
    first = next((i for i, l in enumerate(lines) if l.lstrip().startswith("```")), None)
    if first is None or first >= 12:
        fail("README.md does not open with a code block in its first 12 lines")
    else:
        block = []
        for l in lines[first + 1:]:
            if l.lstrip().startswith("```"):
                break
            block.append(l.rstrip())
        if block != START:
            fail("README.md's first code block is not the two commands for a new machine:\n  %s"
                 % "\n  ".join(block))

    # 3 + 4. subcommands and flags, in reading order
    helps = {}
    subs_seen = set()
    context = None  # ("sub", name) or ("script", path)
    flags_checked = 0
    unplaced = []
    for no, code in code_pieces(text):
        if code is None:
            context = None
            continue
        # tokens: a command (morsegs SUB, scripts/X) or a flag, in order within the piece
        for m in re.finditer(r"(?<![\w/.-])(?:import\s+)?morsegs\s+([A-Za-z][A-Za-z-]*(?:\s+(?!-)[a-z][a-z0-9]*)?)"
                             r"|(?<![\w/.-])(scripts/[\w.-]+)"
                             r"|(?<![\w-])(--[a-z][a-z0-9-]*)"
                             r"|(?<![\w/.-])(mpirun)(?![\w-])", code):
            if m.group(1):
                if m.group(0).startswith("import"):
                    continue
                sub = m.group(1)
                if sub[0].isupper():  # `morsegs COMMAND ...`: a placeholder, any subcommand
                    context = None
                    continue
                # `morsegs bench NAME` has its own --help; elsewhere the next word is an operand
                if not sub.startswith("bench "):
                    sub = sub.split()[0]
                context = ("sub", sub)
                if sub not in subs_seen:
                    subs_seen.add(sub)
                    rc, out = help_text(cli, sub, helps)
                    if rc == 0 and " " in sub:
                        helps[sub] = (rc, out + help_text(cli, "bench", helps)[1])
                    if rc != 0:
                        fail("line %d: `morsegs %s --help` exits %d: %s" % (no, sub, rc, out.strip()[:200]))
            elif m.group(2):
                context = ("script", m.group(2))
            elif m.group(4):
                context = ("other", "mpirun")  # mpirun's own flags are not checked
            else:
                flag = m.group(3)
                flags_checked += 1
                if flag == "--help":
                    continue  # every subcommand named was run with --help above
                if context is None:
                    unplaced.append((no, flag))  # checked at the end against every --help
                elif context[0] == "sub":
                    rc, out = help_text(cli, context[1], helps)
                    if rc == 0 and not has_flag(out, flag):
                        fail("line %d: %s is not in `morsegs %s --help`" % (no, flag, context[1]))
                elif context[0] == "script":
                    path = os.path.join(src, context[1])
                    body = open(path, encoding="utf-8", errors="replace").read() if os.path.isfile(path) else ""
                    if body and not has_flag(body, flag):
                        fail("line %d: %s does not appear in %s" % (no, flag, context[1]))
    if not subs_seen:
        fail("README.md names no `morsegs SUBCOMMAND`")
    for no, flag in unplaced:
        if not any(has_flag(out, flag) for rc, out in helps.values() if rc == 0):
            fail("line %d: %s (no command before it) is in no subcommand's --help" % (no, flag))

    # 5. paths under the repository's top-level folders
    tops = sorted(d for d in os.listdir(src)
                  if os.path.isdir(os.path.join(src, d)) and not d.startswith((".", "build")))
    pat = re.compile(r"(?<![\w/.$-])((?:%s)/[\w./{},*-]*)" % "|".join(map(re.escape, tops)))
    paths_checked = 0
    for no, line in enumerate(lines, 1):
        for m in pat.finditer(line):
            p = m.group(1).split("#")[0].rstrip(".,;:")
            paths_checked += 1
            for alt in expand_braces(p):
                if not glob.glob(os.path.join(src, alt)):
                    fail("line %d: %s does not exist in the repository" % (no, alt))

    print("README.md: %d lines, subcommands %s, %d flags, %d paths checked"
          % (len(lines), " ".join(sorted(subs_seen)), flags_checked, paths_checked))
    for e in errors:
        print("FAIL " + e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
