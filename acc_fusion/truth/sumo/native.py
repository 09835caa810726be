r"""The compiled reader of :class:`~acc_fusion.truth.sumo.source.SumoSource`: libsumo's per-vehicle
reads
in one call.

Per step the SUMO source reads every equipped vehicle's speed and leader.  Through libsumo's
Python functions each read is a SWIG call (argument conversion, a Python object per result);
``sumo_reads.cpp`` (beside this module) makes the same calls to libsumo's C++ API
(``libsumo::Vehicle::getSpeed``, ``libsumo::Vehicle::getLeader``) for all vehicles in one
Python call, writing into numpy arrays, and looks each leader's code up in a C++ table
(``Codes``) without making a Python string of its id.  The values are those of libsumo's own
functions, bit for bit (``tests/test_native.py`` compares whole runs); on the motorway of
``scripts/bench_sumo.py`` the reads cost about 0.4 of the SWIG calls' time.

Built on first use
    There is no compiled code in the wheel: SUMO's C++ headers and the library come with the
    ``eclipse-sumo`` and ``libsumo`` wheels the user installed, so :func:`sumo_reader`
    compiles the extension against *those* (``c++``, or ``$CXX``, with Python's headers) once,
    into a cache directory (``$ACC_FUSION_CACHE``, else ``$XDG_CACHE_HOME/acc_fusion``, else
    ``~/.cache/acc_fusion``), named by a hash of the source, the SUMO version, the libsumo
    library and the Python ABI; later processes load the cached file.  The extension is linked
    to libsumo's ``_libsumo.so``, which ``import libsumo`` has already loaded, so it shares
    the process's one simulation.

When it cannot be built
    :func:`sumo_reader` returns ``None`` and warns once per process with the reason (not
    Linux, no C++ compiler, no SUMO headers, ``eclipse-sumo`` and ``libsumo`` of different
    versions, a failed compilation); the source then reads through libsumo's Python functions,
    with the same values, more slowly.  ``SumoConfig(native=False)`` or the environment
    variable ``ACC_FUSION_NATIVE=0`` skips it without a warning.  The versions must match
    because the headers describe the C++ functions the library exports: compiled against
    other headers, a changed signature would be a crash rather than an error.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.machinery
import importlib.metadata
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import warnings
from importlib import resources
from pathlib import Path
from types import ModuleType

from acc_fusion.core.paths import cache_dir

#: The extension's C++ source, shipped with the package.
SOURCE = "sumo_reads.cpp"
#: Seconds a compilation may take before it counts as failed.
COMPILE_TIMEOUT = 300.0


class NativeUnavailable(Exception):
    """Why the compiled reader cannot be used here (one sentence)."""


@functools.cache
def sumo_reader() -> ModuleType | None:
    """The compiled reader, built on first use and cached; ``None`` (with one
    ``RuntimeWarning`` per process naming the reason) where it cannot be built, or when
    ``ACC_FUSION_NATIVE=0``.

    Its ``read(vids, slots, lookahead, codes, n_pairs, speed, dist, code)`` reads, for each
    vehicle id in the list ``vids`` (in slot ``slots[i]``, an int64 array), ``speed[i]``
    (``getSpeed``) and the leader within ``lookahead`` (``getLeader``): ``dist[i]`` its
    distance, ``code[i] = codes[leader]`` (``-1`` without a leader or a code), ``codes`` being
    its ``Codes()`` table (str to int, with the dict methods the source uses, looked up in
    C++; each slot keeps its last leader's entry, so a leader seen before is not looked up
    again); it returns ``{i: leader id}`` for the leaders whose code has no slot
    (``code % (n_pairs + 1) == 0``).  Its ``state(vids, edges, f, k)`` reads every vehicle's
    position, angle, speed, acceleration and lane position into the rows of ``f`` (``(6, n)``
    float64) and its edge's code in the ``Codes`` table ``edges`` and lane index into ``k``
    (``(2, n)`` int64; the object truth of :mod:`acc_fusion.truth.sumo.objects`).  A failed
    read raises ``libsumo.TraCIException``, as libsumo's functions do.
    """
    if os.environ.get("ACC_FUSION_NATIVE", "1") == "0":
        return None
    try:
        return _load()
    except NativeUnavailable as exc:
        warnings.warn(
            f"the compiled SUMO reader is not available ({exc}); reading through libsumo's "
            "Python functions (same values, slower; SumoConfig(native=False) skips this)",
            RuntimeWarning,
            stacklevel=2,
        )
        return None


def _load() -> ModuleType:
    """Import the extension, compiling it first if it is not in the cache."""
    if not sys.platform.startswith("linux"):
        raise NativeUnavailable(f"it is built on Linux only, this is {sys.platform}")
    import libsumo

    library = Path(getattr(getattr(libsumo, "_libsumo", None), "__file__", "") or "")
    if not library.is_file():
        raise NativeUnavailable("libsumo's compiled module was not found")
    versions = {name: _version(name) for name in ("libsumo", "eclipse-sumo")}
    if versions["libsumo"] != versions["eclipse-sumo"]:
        raise NativeUnavailable(
            f"libsumo {versions['libsumo']} and eclipse-sumo {versions['eclipse-sumo']} differ"
        )
    headers = _sumo_include()
    source = resources.files(__package__).joinpath(SOURCE).read_bytes()
    stat = library.stat()
    key = hashlib.sha256(
        b"\0".join(
            [
                source,
                versions["libsumo"].encode(),
                str(library).encode(),
                f"{stat.st_size}:{stat.st_mtime_ns}".encode(),
                sys.version.encode(),
            ]
        )
    ).hexdigest()[:16]
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    target = cache_dir() / f"_sumo_reads-{key}{suffix}"
    if not target.is_file():
        _compile(source, headers, library, target)
    spec = importlib.util.spec_from_file_location("_sumo_reads", target)
    if spec is None or spec.loader is None:
        raise NativeUnavailable(f"{target} cannot be imported")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except ImportError as exc:
        raise NativeUnavailable(f"{target} does not load: {exc}") from None
    module.init(libsumo.TraCIException)
    return module


def _version(distribution: str) -> str:
    try:
        return importlib.metadata.version(distribution)
    except importlib.metadata.PackageNotFoundError:
        raise NativeUnavailable(f"{distribution} is not installed") from None


def _sumo_include() -> Path:
    """The C++ headers of the eclipse-sumo wheel (``<SUMO_HOME>/include``)."""
    try:
        import sumo
    except ImportError:
        raise NativeUnavailable("eclipse-sumo is not installed") from None
    include = Path(sumo.SUMO_HOME) / "include"
    if not (include / "libsumo" / "Vehicle.h").is_file():
        raise NativeUnavailable(f"SUMO's C++ headers are not in {include}")
    return include


def _compile(source: bytes, headers: Path, library: Path, target: Path) -> None:
    """Compile ``source`` into ``target`` (written whole or not at all: processes building
    it at once each write their own file and rename it)."""
    compiler = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    if not compiler:
        raise NativeUnavailable("no C++ compiler (c++, g++ or $CXX) was found")
    python_include = sysconfig.get_paths()["include"]
    if not Path(python_include, "Python.h").is_file():
        raise NativeUnavailable(f"Python's headers are not in {python_include}")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp_dir = tempfile.TemporaryDirectory(dir=target.parent)
    except OSError as exc:
        raise NativeUnavailable(
            f"the cache directory {target.parent} is not writable: {exc}"
        ) from None
    with tmp_dir as tmp:
        src, out = Path(tmp, SOURCE), Path(tmp, target.name)
        src.write_bytes(source)
        cmd = [
            *compiler.split(),
            "-O2",
            "-std=c++17",
            "-shared",
            "-fPIC",
            f"-I{python_include}",
            f"-I{headers}",
            str(src),
            "-o",
            str(out),
            f"-L{library.parent}",
            f"-l:{library.name}",
            f"-Wl,-rpath,{library.parent}",
        ]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=COMPILE_TIMEOUT)
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise NativeUnavailable(f"{compiler} could not run: {exc}") from None
        if done.returncode != 0:
            lines = done.stderr.strip().splitlines() or ["no message"]
            first = next((line for line in lines if "error" in line), lines[0])
            raise NativeUnavailable(f"{compiler} failed (exit {done.returncode}): {first}")
        os.replace(out, target)
