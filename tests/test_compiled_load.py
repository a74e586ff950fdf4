"""numba and the lidar's compiled scan load with the simulator's build (runtime/compiled.py), not at the first scan in
the run, and without SciPy's linear algebra; a later kernel that needs BLAS still gets it. Fresh interpreters: what a
process has imported is the thing checked."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap


def _child(code: str) -> dict:
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, timeout=300, check=False
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_a_world_with_walls_loads_the_compiled_scan_at_build():
    out = _child("""
        import json, sys
        from racecar_sim import Simulator
        sim = Simulator(world="walker", camera=False)
        from racecar_sim.sensors.laser_kernel import level_scan
        lidar = sim.car.lidar
        built = {"numba": "numba" in sys.modules, "scipy.linalg": "scipy.linalg" in sys.modules,
                 "kernels": len(level_scan.signatures), "scans": [lidar.scans_cast, lidar.one_call_scans]}
        scans = []
        sim.subscribe(lidar.topic, lambda msg: scans.append(msg.ranges))
        sim.run_until(0.1)
        print(json.dumps({**built, "after": [lidar.scans_cast, lidar.one_call_scans], "published": len(scans),
                          "kernels_after": len(level_scan.signatures)}))
    """)
    assert out["numba"] and not out["scipy.linalg"]
    assert out["kernels"] == 1 == out["kernels_after"]  # loaded at build; the run compiled nothing more
    assert out["scans"] == [0, 0]  # the build's scan is not counted as one
    assert out["after"] == [out["published"], out["published"]] and out["published"] >= 2


def test_the_main_job_compiles_nothing_inside_the_run():
    """walker, the camera on and listened to, wall-follow: every kernel the run calls (scan, wall fit, frame finish,
    culling) is loaded by the build and the driver's attach; none is loaded or compiled inside the run."""
    out = _child("""
        import gc, json, sys
        import numba.core.dispatcher as dispatcher
        from racecar_sim import Simulator
        from racecar_sim.runtime.driving import attach_driver

        def loaded():
            return {f"{o.py_func.__module__}.{o.py_func.__name__}": len(o.overloads)
                    for o in gc.get_objects() if isinstance(o, dispatcher.Dispatcher) and o.overloads}

        sim = Simulator(world="walker")
        attach_driver(sim, sim.car, "wall-follow", {})
        frames = []
        sim.subscribe(sim.car.camera.spec.image_topic, frames.append)
        built = loaded()
        registries = "numba.np.arraymath" in sys.modules
        sim.run_until(0.5)
        print(json.dumps({"built": built, "after": loaded(), "frames": len(frames), "registries": registries}))
    """)
    assert out["frames"] >= 10
    assert not out["registries"]  # the cached kernels linked in without numba's compiler registries
    assert {name.rsplit(".", 1)[1] for name in out["built"]} >= {
        "level_scan",
        "fit_wall",
        "finish_rows",
        "cull_records",
    }
    assert out["after"] == out["built"]


def test_an_empty_world_without_camera_does_not_load_numba():
    out = _child("""
        import json, sys
        from racecar_sim import Simulator
        Simulator(world="empty", camera=False)
        print(json.dumps({"numba": "numba" in sys.modules}))
    """)
    assert not out["numba"]


def test_a_kernel_that_needs_blas_still_compiles_and_gives_numpys_answer():
    out = _child("""
        import importlib.util, json, sys
        import numpy as np
        from racecar_sim.runtime.compiled import load_numba
        load_numba()
        import numba
        before = [m for m in ("scipy.linalg", "numba.np.arraymath") if m in sys.modules]

        @numba.njit
        def both(a, b):
            return np.dot(a, b), np.correlate(a, b)

        a, b = np.arange(6.0).reshape(2, 3), np.array([1.0, -2.0, 0.5])
        dot, corr = both(a[0], b)
        from numba.np import arraymath
        print(json.dumps({"before": before, "have_blas": arraymath._HAVE_BLAS,
                          "scipy": importlib.util.find_spec("scipy") is not None,
                          "dot": [float(dot), float(np.dot(a[0], b))],
                          "corr": [corr.tolist(), np.correlate(a[0], b).tolist()]}))
    """)
    assert out["before"] == []  # load_numba loads neither SciPy's linear algebra nor numba's registries
    assert out["have_blas"] == out["scipy"]
    assert out["dot"][0] == out["dot"][1] and out["corr"][0] == out["corr"][1]


def test_other_cached_kernels_load_numbas_own_way(tmp_path):
    """Only racecar-sim's kernels load without numba's registries: a user's cached kernel, in a process where
    load_numba ran, is loaded as numba loads it (its registries first) and gives the same answer as when compiled."""
    (tmp_path / "user_kernel.py").write_text(
        "import numba\nimport numpy as np\n\n"
        "@numba.njit(cache=True)\n"
        "def spread(a):\n    seen = set()\n    for x in a:\n        seen.add(int(x))\n"
        "    return np.sort(a)[-1] - np.sort(a)[0] + len(seen)\n"
    )
    code = f"""
        import json, sys
        sys.path.insert(0, {str(tmp_path)!r})
        import numpy as np
        from racecar_sim.runtime.compiled import load_numba
        load_numba()
        before = "numba.np.arraymath" in sys.modules
        from user_kernel import spread
        value = spread(np.array([3.0, -1.0, 3.0, 7.5]))
        print(json.dumps({{"before": before, "after": "numba.np.arraymath" in sys.modules, "value": value,
                          "hits": sum(spread.stats.cache_hits.values())}}))
    """
    compiled, loaded = _child(code), _child(code)  # the first compiles (and caches), the second loads
    assert compiled["value"] == loaded["value"] == 8.5 + 3
    assert [compiled["hits"], loaded["hits"]] == [0, 1]
    assert not loaded["before"] and loaded["after"]  # numba's own load: its registries, as always


def test_our_cached_kernels_run_numbas_inlined_code_without_importing_it(tmp_path):
    """A kernel of racecar-sim's (here one named as the generated tyre kernels are) that inlines numba's own array,
    string and exception code: loaded from the cache, its environments are rebuilt without importing numba's
    lowering modules, and it gives what it gave when compiled - values, inf from a division by zero (numpy's error
    model), and the exception it raises with its arguments."""
    (tmp_path / "racecar_tyre_kernels_probe.py").write_text(
        "import numpy as np\nfrom numba import njit\n\n"
        '@njit(cache=True, error_model="numpy")\n'
        "def probe(n, a):\n    out = np.empty(n)\n    for i in range(n):\n"
        "        out[i] = a[i % a.size] / (i - 1.0)\n"
        '    if n > 10:\n        raise ValueError("too many", n)\n'
        '    return out, len(str(n) + "x"), out.copy().sum()\n'
    )
    code = f"""
        import json, sys
        sys.path.insert(0, {str(tmp_path)!r})
        import numpy as np
        from racecar_sim.runtime.compiled import load_numba
        load_numba()
        from racecar_tyre_kernels_probe import probe
        out, length, total = probe(4, np.arange(3.0))
        try:
            probe(11, np.arange(3.0))
            raised = None
        except ValueError as exc:
            raised = list(exc.args)
        lowering = ("numba.np.arrayobj", "numba.cpython.unicode")
        print(json.dumps({{"out": repr(out.tolist()), "length": length, "total": repr(total), "raised": raised,
                          "hits": sum(probe.stats.cache_hits.values()),
                          "imported": [m for m in lowering if m in sys.modules]}}))
    """
    compiled, loaded = _child(code), _child(code)  # the first compiles (and caches), the second loads
    assert [compiled["hits"], loaded["hits"]] == [0, 1]
    assert loaded["imported"] == [] and compiled["imported"] != []
    assert loaded["out"] == compiled["out"] == "[-0.0, inf, 2.0, 0.0]"
    assert loaded["total"] == compiled["total"] == "inf"
    assert loaded["length"] == compiled["length"] == 2
    assert loaded["raised"] == compiled["raised"] == ["too many", 11]


def test_a_numba_laid_out_otherwise_is_left_as_it_is():
    from racecar_sim.runtime.compiled import _light_loads

    class Cache:  # no _load_overload / _guard_against_spurious_io_errors to build on
        def load_overload(self, sig, target_context):
            return "numba's own"

    assert not _light_loads(Cache)
    assert Cache().load_overload(None, None) == "numba's own"
