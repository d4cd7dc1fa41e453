"""Tiny runner shared by tests/python: runs every test_* function of the calling module,
prints one line each, exits 1 if any failed (ctest reads the exit code). Also the paths the
tests need and a check that `morsegs` is the built package, not some other one."""
import os
import sys
import tempfile
import traceback

SOURCE_DIR = os.environ.get("MGS_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BINARY_DIR = os.environ.get("MGS_BINARY_DIR", os.path.join(SOURCE_DIR, "build"))
CLI = os.environ.get("MGS_CLI", os.path.join(BINARY_DIR, "apps", "morsegs"))


def tmpdir(name):
    return tempfile.mkdtemp(prefix="mgs_py_%s_" % name)


def raises(exc, fn, *args, match=None, **kwargs):
    """Asserts fn(*args, **kwargs) raises exc (and its message contains `match`); returns it."""
    try:
        fn(*args, **kwargs)
    except exc as e:
        if match is not None and match not in str(e):
            raise AssertionError("%s raised %r, message lacks %r" % (getattr(fn, "__name__", fn), e, match))
        return e
    except Exception as e:  # noqa: BLE001 - any other type is the failure being reported
        raise AssertionError("%s raised %s(%s), expected %s" % (getattr(fn, "__name__", fn), type(e).__name__, e,
                                                                 exc.__name__))
    raise AssertionError("%s did not raise %s" % (getattr(fn, "__name__", fn), exc.__name__))


def run(namespace):
    import morsegs
    print("morsegs from", os.path.dirname(morsegs.__file__))
    failed = 0
    for name in sorted(k for k in namespace if k.startswith("test_") and callable(namespace[k])):
        try:
            namespace[name]()
            print("ok   ", name)
        except Exception:  # noqa: BLE001
            failed += 1
            print("FAIL ", name)
            traceback.print_exc()
    sys.stdout.flush()
    sys.exit(1 if failed else 0)
