#!/usr/bin/python3
"""Dependencies point one way: common/ at the bottom, firmware/ and host/
siblings above it, neither including the other.

Who may include what (by the folder the including file lives in):
    common/          common/
    firmware/        common/, firmware/
    host/            common/, host/
    bench/           common/, host/, bench/
    tests/firmware/  common/, firmware/, tests/   (tests OF firmware code)
    tests/ (rest)    common/, host/, tests/
A test of firmware code lives in tests/firmware/ and may include firmware/
but not host/: where a board must agree with the simulator, both sides use
the code they share in common/ (e.g. the loop stepper), not each other.

Two things are checked:
  1. every #include "..." / <...> of a C/C++ file under common/, firmware/,
     host/, bench/ and tests/: resolved against the including file's folder
     and against every source root (common/, host/, firmware/, the board
     folders firmware/bsp/*/); it is a violation when it resolves only to
     files the includer may not include. Includes that resolve nowhere
     (system and generated headers) are not the rule's business.
  2. the include directories CMake gives a target (target_include_directories,
     include_directories) in every CMakeLists.txt / *.cmake: a directory in an
     area the target's sources may not include is a violation. A target whose
     sources cannot be read from its add_executable / add_library call (a
     name built from a variable) counts as living in the CMake file's folder.

Usage:
    check_include_direction.py [ROOT]     check the tree at ROOT (default: this repository)
    check_include_direction.py --self-test
        build small trees that break each direction and check that every one
        is caught, and that a tree following the rule passes.
Exit status: 0 the tree follows the rule, 1 violations (listed), 2 usage.
"""
import os
import re
import sys
import tempfile

SOURCE_EXTENSIONS = (".hpp", ".cpp", ".h", ".c", ".hh", ".cc", ".inc")
SCANNED_TOP = ("common", "firmware", "host", "bench", "tests")

# area of the includer -> areas it may include
ALLOWED = {
    "common": {"common"},
    "firmware": {"common", "firmware"},
    "host": {"common", "host"},
    "bench": {"common", "host", "bench"},
    "tests/firmware": {"common", "firmware", "tests"},
    "tests": {"common", "host", "tests"},
}

INCLUDE_RE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def area_of(rel):
    """The area of a path relative to the root (None: outside every area)."""
    parts = rel.replace(os.sep, "/").split("/")
    if parts[0] == "tests":
        return "tests/firmware" if len(parts) > 1 and parts[1] == "firmware" else "tests"
    return parts[0] if parts[0] in ALLOWED else None


def included_area(area):
    """The area an included file counts as (a test file is 'tests')."""
    return "tests" if area == "tests/firmware" else area


def rel(root, path):
    return os.path.relpath(os.path.normpath(path), root).replace(os.sep, "/")


def source_roots(root):
    roots = [os.path.join(root, d) for d in ("common", "host", "firmware")]
    bsp = os.path.join(root, "firmware", "bsp")
    if os.path.isdir(bsp):
        roots += [os.path.join(bsp, d) for d in sorted(os.listdir(bsp)) if os.path.isdir(os.path.join(bsp, d))]
    return roots


def check_includes(root):
    violations = []
    roots = source_roots(root)
    for top in SCANNED_TOP:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if not name.endswith(SOURCE_EXTENSIONS):
                    continue
                path = os.path.join(dirpath, name)
                me = area_of(rel(root, path))
                with open(path, encoding="utf-8", errors="replace") as f:
                    for lineno, line in enumerate(f, 1):
                        m = INCLUDE_RE.match(line)
                        if not m:
                            continue
                        bracket, target = m.groups()
                        bases = ([dirpath] if bracket == '"' else []) + roots
                        found = []
                        for base in bases:
                            candidate = os.path.normpath(os.path.join(base, target))
                            if os.path.isfile(candidate):
                                found.append(rel(root, candidate))
                        areas = {included_area(area_of(p)) for p in found}
                        if found and not (areas & ALLOWED[me]):
                            violations.append(f"{rel(root, path)}:{lineno}: {me}/ includes {found[0]} "
                                              f"({me}/ may include {', '.join(sorted(ALLOWED[me]))})")
    return violations


def cmake_commands(text):
    """(name, [arguments]) of every command call, comments removed."""
    text = re.sub(r"#[^\n]*", "", text)
    for m in re.finditer(r"\b([A-Za-z_][A-Za-z0-9_]*)\s*\(([^()]*(?:\([^()]*\)[^()]*)*)\)", text):
        yield m.group(1).lower(), m.group(2).split()


def expand(value, variables):
    for _ in range(5):
        value = re.sub(r"\$\{([A-Za-z0-9_]+)\}", lambda m: variables.get(m.group(1), m.group(0)), value)
    return value


def check_cmake_include_dirs(root):
    violations = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d not in ("build", ".git"))
        for name in sorted(filenames):
            if name != "CMakeLists.txt" and not name.endswith(".cmake"):
                continue
            path = os.path.join(dirpath, name)
            here = area_of(rel(root, dirpath))
            if here is None:
                continue
            with open(path, encoding="utf-8", errors="replace") as f:
                commands = list(cmake_commands(f.read()))
            variables = {"CMAKE_SOURCE_DIR": root, "PROJECT_SOURCE_DIR": root,
                         "CMAKE_CURRENT_SOURCE_DIR": dirpath, "CMAKE_CURRENT_LIST_DIR": dirpath}
            sources = {}
            for cmd, args in commands:
                if cmd == "set" and len(args) == 2:
                    variables[args[0]] = expand(args[1], variables)
                elif cmd in ("add_executable", "add_library") and args and "${" not in args[0]:
                    files = [a for a in args[1:] if a.endswith(SOURCE_EXTENSIONS) and "$" not in a]
                    sources[args[0]] = [rel(root, os.path.join(dirpath, a)) for a in files]
            for cmd, args in commands:
                if cmd == "target_include_directories" and args:
                    target, dirs = args[0], args[1:]
                    owners = {area_of(s) for s in sources.get(target, [])} or {here}
                elif cmd == "include_directories":
                    target, dirs, owners = "(directory)", args, {here}
                else:
                    continue
                for d in dirs:
                    if d in ("PUBLIC", "PRIVATE", "INTERFACE", "SYSTEM", "BEFORE", "AFTER"):
                        continue
                    value = expand(d, variables)
                    if "${" in value or "$<" in value:
                        continue  # not known at this level
                    full = value if os.path.isabs(value) else os.path.join(dirpath, value)
                    dir_area = area_of(rel(root, full)) if rel(root, full) != ".." and not rel(root, full).startswith("../") else None
                    if dir_area is None:
                        continue
                    for owner in owners:
                        if owner is not None and included_area(dir_area) not in ALLOWED[owner]:
                            violations.append(f"{rel(root, path)}: {target} ({owner}/) gets include directory "
                                              f"{rel(root, full)} ({owner}/ may include "
                                              f"{', '.join(sorted(ALLOWED[owner]))})")
    return violations


def check(root):
    root = os.path.abspath(root)
    return check_includes(root) + check_cmake_include_dirs(root)


def write(root, relpath, text):
    path = os.path.join(root, relpath)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


CLEAN_TREE = {
    "common/piezoloop/core.hpp": "#pragma once\n#include <cstdint>\n",
    "common/piezoloop/usb/descriptors.hpp": '#pragma once\n#include "piezoloop/core.hpp"\n',
    "firmware/app/app.hpp": '#pragma once\n#include "piezoloop/usb/descriptors.hpp"\n#include "board_config.hpp"\n',
    "firmware/bsp/qemu/board_config.hpp": "#pragma once\n",
    "firmware/CMakeLists.txt": "set(FW_DIR ${CMAKE_CURRENT_SOURCE_DIR})\n"
                               "target_include_directories(fw INTERFACE ${FW_DIR})\n",
    "host/link/usb.cpp": '#include "piezoloop/usb/descriptors.hpp"\n#include "link/usb.hpp"\n',
    "host/link/usb.hpp": "#pragma once\n",
    "tests/firmware/replay.cpp": '#include "app/app.hpp"\n#include "piezoloop/core.hpp"\n',
    "tests/host/test_usb.cpp": '#include "link/usb.hpp"\n#include <gtest/gtest.h>\n',
    "tests/CMakeLists.txt": "add_executable(replay firmware/replay.cpp)\n"
                            "target_include_directories(replay PRIVATE ${CMAKE_SOURCE_DIR}/firmware)\n"
                            "target_include_directories(${t} PRIVATE ${CMAKE_SOURCE_DIR}/host)\n",
}

# Each breaks the rule once: (what, files added to or replacing the clean tree).
BROKEN_TREES = [
    ("host includes firmware", {"host/link/usb.cpp": '#include "../../firmware/app/app.hpp"\n'}),
    ("host includes firmware through a root", {"host/link/usb.cpp": '#include "app/app.hpp"\n'}),
    ("firmware includes host", {"firmware/app/app.hpp": '#include "link/usb.hpp"\n'}),
    ("common includes host", {"common/piezoloop/core.hpp": '#include "link/usb.hpp"\n'}),
    ("common includes firmware", {"common/piezoloop/core.hpp": '#include "app/app.hpp"\n'}),
    ("a host test includes firmware", {"tests/host/test_usb.cpp": '#include "app/app.hpp"\n'}),
    ("a firmware test includes host", {"tests/firmware/replay.cpp": '#include "link/usb.hpp"\n'}),
    ("bench includes firmware", {"bench/bench.cpp": '#include "../firmware/app/app.hpp"\n'}),
    ("a host test target gets firmware/ as include directory",
     {"tests/CMakeLists.txt": "foreach(t a b)\n  target_include_directories(${t} PRIVATE ${CMAKE_SOURCE_DIR}/firmware)\n"
                              "endforeach()\n"}),
    ("a firmware test target gets host/ as include directory",
     {"tests/CMakeLists.txt": "add_executable(replay firmware/replay.cpp)\n"
                              "target_include_directories(replay PRIVATE ${CMAKE_SOURCE_DIR}/host)\n"}),
    ("host gets firmware/ as include directory",
     {"host/CMakeLists.txt": "include_directories(${CMAKE_CURRENT_SOURCE_DIR}/../firmware)\n"}),
    ("firmware gets host/ as include directory",
     {"firmware/CMakeLists.txt": "set(H ${CMAKE_SOURCE_DIR}/host)\ntarget_include_directories(fw INTERFACE ${H})\n"}),
]


def self_test():
    failures = 0
    with tempfile.TemporaryDirectory() as tmp:
        clean = os.path.join(tmp, "clean")
        for p, t in CLEAN_TREE.items():
            write(clean, p, t)
        found = check(clean)
        if found:
            print("self-test: the clean tree was rejected:\n  " + "\n  ".join(found))
            failures += 1
        for i, (what, files) in enumerate(BROKEN_TREES):
            tree = os.path.join(tmp, f"broken{i}")
            for p, t in {**CLEAN_TREE, **files}.items():
                write(tree, p, t)
            found = check(tree)
            print(f"self-test: {what}: {'caught: ' + found[0] if found else 'NOT CAUGHT'}")
            failures += 0 if found else 1
    print(f"self-test: {'ok' if failures == 0 else f'{failures} failure(s)'}")
    return 1 if failures else 0


def main(argv):
    if len(argv) == 2 and argv[1] == "--self-test":
        return self_test()
    if len(argv) > 2 or (len(argv) == 2 and argv[1].startswith("-")):
        print(__doc__.split("Usage:")[1].split("Exit status")[0], file=sys.stderr)
        return 2
    root = argv[1] if len(argv) == 2 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    violations = check(root)
    for v in violations:
        print(v)
    print(f"include direction: {len(violations)} violation(s)")
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
