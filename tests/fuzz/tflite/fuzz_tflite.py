#!/usr/bin/python3
"""A coverage-guided, structure-aware mutation fuzzer for the TFLite reader (models/edgefusion_models/
tflite.py, which `edgefusion model import --tflite` runs). libFuzzer cannot drive Python and atheris
is not in Debian 12, so this is a small one of our own, with the standard library and numpy only.

  Target     tflite.parse(bytes), then tflite.dequantize() of every constant tensor it returns.
  Oracle     the reader's own TFLiteError (a clear message naming the place) is the expected answer to
             a bad file; any other exception is a finding, and so is one input taking longer than
             --timeout seconds. The first input of each finding (an exception type at a line of the
             reader) is written to --findings as finding-<n>.tflite with its traceback beside it
             (.txt); any finding makes the exit status 1.
  Coverage   line arcs (previous line, line) inside tflite.py, recorded with sys.settrace for the
             frames of that file only. An input that reaches an arc no earlier input reached joins
             the corpus (in memory, and in --corpus when given).
  Mutations  byte level (bit flips, interesting bytes and 32-bit words, inserts, deletes, copies,
             splices with another corpus entry), and structure-aware: the reader's own reads of
             the input are recorded (every position and size it bounds-checks: vtable entries,
             offsets, counts, scalars), and a third of the mutations rewrite one of those places with
             an interesting value of its size, so mutations land on the fields the parser decodes.
  Report     executions, seconds, what ended the run, corpus size, arcs, and functions reached out
             of the functions tflite.py defines (from its syntax tree), as one `key value` line each.

  fuzz_tflite.py [--runs N] [--seconds S] [--seeds DIR] [--corpus DIR] [--findings DIR] [--seed N]
  Without --seeds the run starts from one empty input (the "before the seed corpus" figure).
Exit status: 0 no finding, 1 findings, 77 skipped (numpy or the reader cannot be imported; the
message says which).
"""
import argparse
import ast
import os
import random
import struct
import sys
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
sys.path.insert(0, os.path.join(REPO, "models"))

try:
    import numpy  # noqa: F401  (the reader's arrays)
    from edgefusion_models import tflite
except ImportError as e:  # a machine without python3-numpy: the ctest test skips
    print(f"fuzz_tflite: skipped: cannot import the reader's modules ({e}); install python3-numpy")
    sys.exit(77)

TARGET_FILE = os.path.abspath(tflite.__file__)
if TARGET_FILE.endswith(".pyc"):
    TARGET_FILE = TARGET_FILE[:-1]

INTERESTING8 = [0, 1, 2, 4, 8, 0x10, 0x20, 0x40, 0x7F, 0x80, 0xFF]
INTERESTING32 = [0, 1, 2, 3, 4, 8, 12, 16, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0xFFFF, 0x10000,
                 0x7FFFFFFF, 0x80000000, 0xFFFFFFFF, 0xFFFFFFFE, 0xFFFFFFFC]


# ---- Coverage ----

def traced(fn, *args):
    """Calls fn(*args) with the arcs and functions of TARGET_FILE it reaches recorded (sys.settrace,
    that file's frames only). Returns (arcs, functions, the exception it raised or None)."""
    arcs, funcs, prev = set(), set(), {}

    def local(frame, event, arg):
        if event == "line":
            arcs.add((frame.f_code.co_firstlineno, prev.get(id(frame), 0), frame.f_lineno))
            prev[id(frame)] = frame.f_lineno
        return local

    def global_(frame, event, arg):
        if frame.f_code.co_filename != TARGET_FILE:
            return None
        funcs.add((frame.f_code.co_name, frame.f_code.co_firstlineno))
        return local

    sys.settrace(global_)
    try:
        fn(*args)
        raised = None
    except Exception as e:  # noqa: BLE001: the caller sorts the reader's own error from the rest
        raised = e
    finally:
        sys.settrace(None)
    return arcs, funcs, raised


def defined_functions(path):
    """(name, first line) of every function and method tflite.py defines, lambdas included: the
    denominator of 'functions reached'. A decorated function's code starts at its first decorator."""
    tree = ast.parse(open(path, encoding="utf-8").read())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            line = min([node.lineno] + [d.lineno for d in node.decorator_list])
            out.add((node.name, line))
        elif isinstance(node, ast.Lambda):
            out.add(("<lambda>", node.lineno))
    return out


# ---- The target ----

class Reads:
    """The places the reader bounds-checks while parsing one input (position, size)."""

    def __init__(self):
        self.places = []
        self._orig = tflite._Buf._need

    def __enter__(self):
        places = self.places
        orig = self._orig

        def need(buf, pos, size, what):
            if 0 <= pos and size in (1, 2, 4, 8) and len(places) < 4096:
                places.append((pos, size))
            return orig(buf, pos, size, what)
        tflite._Buf._need = need
        return self

    def __exit__(self, *exc):
        tflite._Buf._need = self._orig
        return False


def target(data: bytes):
    model = tflite.parse(data, "fuzz.tflite")
    for t in model.tensors:
        if t.data is not None:
            tflite.dequantize(t)
    for t in range(-1, len(model.tensors)):
        model.describe(t)


# ---- Mutations ----

def mutate(data: bytes, corpus, places, rng: random.Random) -> bytes:
    b = bytearray(data)
    for _ in range(rng.choice((1, 1, 1, 2, 3, 4))):
        choice = rng.random()
        if places and choice < 0.34:  # structure-aware: a field the reader decodes
            pos, size = rng.choice(places)
            if pos + size > len(b):
                continue
            if size == 1:
                b[pos] = rng.choice(INTERESTING8 + [rng.randrange(256)])
            elif size == 2:
                v = rng.choice([0, 1, 2, 4, 6, 8, 0xFFFF, 0x8000, rng.randrange(65536),
                                (struct.unpack_from("<H", b, pos)[0] + rng.choice((-4, -2, 2, 4))) & 0xFFFF])
                struct.pack_into("<H", b, pos, v)
            else:
                old = struct.unpack_from("<I", b, pos)[0]
                v = rng.choice(INTERESTING32 + [len(b), len(b) - pos, rng.randrange(1 << 32),
                                                (old + rng.choice((-8, -4, -1, 1, 4, 8))) & 0xFFFFFFFF])
                struct.pack_into("<I", b, pos, v & 0xFFFFFFFF)
        elif choice < 0.5 and b:
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
        elif choice < 0.6 and b:
            b[rng.randrange(len(b))] = rng.choice(INTERESTING8)
        elif choice < 0.7 and len(b) >= 4:
            i = rng.randrange(len(b) - 3)
            struct.pack_into("<I", b, i, rng.choice(INTERESTING32))
        elif choice < 0.78:
            i = rng.randrange(len(b) + 1)
            b[i:i] = bytes(rng.randrange(256) for _ in range(rng.choice((1, 2, 4, 8))))
        elif choice < 0.86 and b:
            i = rng.randrange(len(b))
            del b[i:i + rng.choice((1, 2, 4, 8, 16))]
        elif choice < 0.93 and len(b) >= 8:
            n = rng.choice((4, 8, 16))
            src, dst = rng.randrange(len(b)), rng.randrange(len(b))
            b[dst:dst + n] = b[src:src + n]
        elif corpus:
            other = rng.choice(corpus)
            cut = rng.randrange(len(b) + 1)
            b = b[:cut] + other[rng.randrange(len(other) + 1):]
    if len(b) > 1 << 16:
        del b[1 << 16:]
    return bytes(b)


# ---- The loop ----

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=0, help="stop after this many executions (0: no limit)")
    ap.add_argument("--seconds", type=float, default=10, help="stop after this long (0: no limit)")
    ap.add_argument("--seeds", help="folder of seed files (tests/fuzz/corpus/tflite)")
    ap.add_argument("--corpus", help="folder where new inputs are written (never the committed seeds)")
    ap.add_argument("--findings", default=".", help="folder for finding-<n>.tflite and its traceback")
    ap.add_argument("--timeout", type=float, default=2.0, help="seconds one input may take")
    ap.add_argument("--seed", type=int, default=0, help="random seed (0: from the clock)")
    args = ap.parse_args()
    rng = random.Random(args.seed or time.time_ns())

    seen_arcs, seen_funcs = set(), set()
    corpus, corpus_places = [], []
    findings = 0
    sites = set()  # (exception type, line in tflite.py) of the findings so far
    runs = 0
    start = time.monotonic()

    def execute(data: bytes):
        """Runs one input; returns (new coverage?, the places the reader read)."""
        nonlocal findings, runs
        runs += 1
        t0 = time.monotonic()
        with Reads() as reads:
            arcs, funcs, raised = traced(target, data)
        elapsed = time.monotonic() - t0
        error = None
        if raised is not None and not isinstance(raised, tflite.TFLiteError):
            error = "".join(traceback.format_exception(type(raised), raised, raised.__traceback__))
        elif elapsed > args.timeout:
            error = f"timeout: one input took {elapsed:.2f} s (limit {args.timeout} s)\n"
        if error is not None and raised is not None:
            # One finding per place: the exception's type and the innermost line of the reader.
            tb = traceback.extract_tb(raised.__traceback__)
            inner = [f for f in tb if os.path.abspath(f.filename) == TARGET_FILE] or tb
            site = (type(raised).__name__, inner[-1].lineno)
            if site in sites:
                error = None
            sites.add(site)
        if error is not None:
            findings += 1
            os.makedirs(args.findings, exist_ok=True)
            path = os.path.join(args.findings, f"finding-{findings}.tflite")
            with open(path, "wb") as f:
                f.write(data)
            with open(path + ".txt", "w") as f:
                f.write(error)
            print(f"fuzz_tflite: FINDING {findings} ({len(data)} bytes) -> {path}\n{error}", flush=True)
        new = not arcs <= seen_arcs
        seen_arcs.update(arcs)
        seen_funcs.update(funcs)
        return new, reads.places

    seeds = []
    if args.seeds:
        for name in sorted(os.listdir(args.seeds)):
            with open(os.path.join(args.seeds, name), "rb") as f:
                seeds.append(f.read())
    if not seeds:
        seeds = [b""]
    for s in seeds:
        _, places = execute(s)
        corpus.append(s)
        corpus_places.append(places)

    ended = "runs"
    while True:
        if args.runs and runs >= args.runs:
            ended = "runs"
            break
        if args.seconds and time.monotonic() - start >= args.seconds:
            ended = "time"
            break
        i = rng.randrange(len(corpus))
        data = mutate(corpus[i], corpus, corpus_places[i], rng)
        new, places = execute(data)
        if new:
            corpus.append(data)
            corpus_places.append(places)
            if args.corpus:
                os.makedirs(args.corpus, exist_ok=True)
                with open(os.path.join(args.corpus, f"cov-{len(corpus):05d}.tflite"), "wb") as f:
                    f.write(data)

    defined = defined_functions(TARGET_FILE)
    reached = {f for f in seen_funcs if f in defined}
    print(f"executions {runs}")
    print(f"seconds {time.monotonic() - start:.1f}")
    print(f"ended_by {ended}")
    print(f"corpus {len(corpus)}")
    print(f"arcs {len(seen_arcs)}")
    print(f"functions_reached {len(reached)}")
    print(f"functions_defined {len(defined)}")
    print(f"findings {findings}")
    missed = sorted(defined - reached, key=lambda f: f[1])
    if missed:
        print("functions_not_reached " + " ".join(f"{n}:{line}" for n, line in missed))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
