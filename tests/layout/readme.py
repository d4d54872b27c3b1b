#!/usr/bin/env python3
"""The README stays an index that is true (issue: a short README).

  readme.py REPO_DIR TALLYD TALLY

- Every file in docs/ (*.md) has its line in the README's "Documentation"
  list, and every docs/ path the README names exists.
- Every command the README shows exists as shown: `./scripts/X` is a file;
  `tallyd SUB` and `tally SUB` are subcommands their `--help` lists, and each
  `--flag` after them is an option that subcommand's `--help` lists.
A README that names a command or a flag that is gone fails here, with the
line.
"""
import os
import re
import subprocess
import sys


def help_text(binary, *words):
    result = subprocess.run([binary, *words, "--help"], capture_output=True, text=True, timeout=60)
    return result.stdout + result.stderr


def subcommands(text):
    block = text.split("Subcommands:", 1)[1] if "Subcommands:" in text else ""
    return set(re.findall(r"^  ([a-z][a-z0-9-]*)\s", block, re.M))


def command_lines(readme):
    """The lines of the README's indented code blocks, joined where they continue with a backslash."""
    lines, current = [], ""
    for raw in readme.splitlines():
        if not raw.startswith("    "):
            current = ""
            continue
        text = raw.strip()
        current = current + " " + text.rstrip("\\") if current else text.rstrip("\\")
        if not text.endswith("\\"):
            lines.append(current.split("#", 1)[0].strip())
            current = ""
    return [line for line in lines if line]


def check_command(words, binaries, errors, line):
    """words: from the program's name on."""
    program = words[0]
    if program.startswith("./scripts/") or program.startswith("scripts/"):
        if not os.path.isfile(os.path.join(binaries["repo"], program)):
            errors.append("%s: no such script (%s)" % (program, line))
        return
    if program not in ("tallyd", "tally"):
        return
    top = help_text(binaries[program])
    subs = subcommands(top)
    sub = next((w for w in words[1:] if not w.startswith("-")), None)
    if sub is None or sub not in subs:
        errors.append("%s: '%s' is not one of its subcommands %s (%s)" % (program, sub, sorted(subs), line))
        return
    options = help_text(binaries[program], sub) + top
    for word in words[1:]:
        if word == "--":
            break  # the application's own arguments follow
        if word.startswith("--"):
            flag = word.split("=", 1)[0]
            if not re.search(r"(^|[\s,])%s\b" % re.escape(flag), options, re.M):
                errors.append("%s %s: no option %s (%s)" % (program, sub, flag, line))


def main():
    repo, tallyd, tally = sys.argv[1:4]
    readme = open(os.path.join(repo, "README.md"), encoding="utf-8").read()
    errors = []
    docs = sorted(f for f in os.listdir(os.path.join(repo, "docs")) if f.endswith(".md"))
    index = readme.split("## Documentation", 1)[1] if "## Documentation" in readme else ""
    for doc in docs:
        if not re.search(r"^- docs/%s: \S" % re.escape(doc), index, re.M):
            errors.append("docs/%s is not in the README's Documentation list (a line '- docs/%s: what it holds')" %
                          (doc, doc))
    for named in sorted(set(re.findall(r"docs/[\w./-]+\.(?:md|png)", readme))):
        if not os.path.exists(os.path.join(repo, named)):
            errors.append("the README names %s, which does not exist" % named)
    binaries = {"repo": repo, "tallyd": tallyd, "tally": tally}
    commands = 0
    for line in command_lines(readme):
        for part in re.split(r"&&|\|\||;|\(|\)", line):
            words = [w for w in part.split() if not re.match(r"^[A-Z_]+=", w)]
            words = [w for w in words if w not in ("sudo", "xvfb-run", "-a")]
            if words:
                commands += 1
                check_command(words, binaries, errors, line)
    if errors:
        print("README:\n  " + "\n  ".join(errors))
        sys.exit(1)
    print("README: %d docs files indexed, %d commands, every one exists as shown" % (len(docs), commands))


if __name__ == "__main__":
    main()
