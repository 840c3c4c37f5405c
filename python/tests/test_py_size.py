"""Size callables: f(x, y, z) goes through the library's C callback field. The field it gives,
its calls from the run's threads (each with the GIL), and its exceptions, which end the run and
are raised by mesh() instead of crashing it."""
import math
import threading

import numpy
import pytest

import packmesh


def graded(x, y, z):
    return 0.1 + 0.05 * x


def test_callable_is_the_same_field_as_the_expression():
    f = packmesh.mesh("case:qi1", size=graded)
    e = packmesh.mesh("case:qi1", size="0.1+0.05*x")
    assert numpy.array_equal(f.nodes, e.nodes) and numpy.array_equal(f.triangles, e.triangles)
    assert f.stats["size"] == "python callable graded"


def test_callable_grades_the_mesh_as_expected():
    """qi1 is [-1, 1] x [-2, 2]. With d = 0.1 + 0.05 x the nodes number about the integral of
    dA / (sqrt(3)/2 d^2): 4 / (sqrt(3)/2) * 20 * (1/0.05 - 1/0.15) = 1232 (924 at d = 0.1), and the
    half x < 0 holds (1/0.05 - 1/0.1) / (1/0.1 - 1/0.15) = 3 times the nodes of the half x > 0."""
    graded_mesh = packmesh.mesh("case:qi1", size=graded)
    uniform = packmesh.mesh("case:qi1", size=0.1)
    n, n0 = len(graded_mesh.nodes), len(uniform.nodes)
    assert abs(n / 1232 - 1) < 0.15, n
    assert abs(n0 / 924 - 1) < 0.15, n0
    assert 1.2 < n / n0 < 1.5
    x = graded_mesh.nodes[:, 0]
    left, right = numpy.count_nonzero(x < 0), numpy.count_nonzero(x > 0)
    assert 2.2 < left / right < 3.8, (left, right)


@pytest.mark.parametrize("method", ["bubble", "psys"])
def test_callable_from_two_threads(method):
    callers = set()

    def f(x, y, z):
        callers.add(threading.get_ident())
        return 0.1 + 0.05 * x

    two = packmesh.mesh("case:qi1", method=method, size=f, threads=2)
    assert len(callers) >= 2, "the field was not evaluated from the run's threads"
    one = packmesh.mesh("case:qi1", method=method, size=f, threads=1)
    assert numpy.array_equal(one.nodes, two.nodes)


class Boom(Exception):
    pass


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("method", ["bubble", "psys", "gmsh-frontal"])
def test_exception_in_the_middle_of_a_run(method, threads):
    calls = [0]
    lock = threading.Lock()

    def f(x, y, z):
        with lock:
            calls[0] += 1
            if calls[0] > 5000:
                raise Boom(f"call {calls[0]}")
        return 0.1

    with pytest.raises(Boom, match="call 5001") as e:
        packmesh.mesh("case:qi1", method=method, size=f, threads=threads)
    assert any("raised by the size function at" in n for n in getattr(e.value, "__notes__", []))
    # No call after the failure reached Python, and the module is usable afterwards.
    assert calls[0] == 5001
    assert len(packmesh.mesh("case:qi1", size=0.3).nodes) > 0


def test_exception_at_the_first_call():
    def f(x, y, z):
        return 1 / 0

    with pytest.raises(ZeroDivisionError):
        packmesh.mesh("case:qi1", size=f, threads=2)


def test_callable_returning_no_number():
    with pytest.raises(TypeError):
        packmesh.mesh("case:qi1", size=lambda x, y, z: "0.1")
    with pytest.raises(TypeError):
        packmesh.mesh("case:qi1", size=lambda x, y: 0.1)


def test_callable_returning_a_bad_size_is_judged_by_the_library():
    with pytest.raises(ValueError, match=r"size 'python callable <lambda>' is -1 at vertex"):
        packmesh.mesh("case:qi1", size=lambda x, y, z: -1.0)
    with pytest.raises(ValueError, match="sizes must be finite"):
        packmesh.mesh("case:qi1", size=lambda x, y, z: math.nan)


def test_callable_in_quality():
    m = packmesh.mesh("case:qi1", size=0.2)
    q = packmesh.quality(m, size=lambda x, y, z: 0.2)
    ratio = q.summary["tri"]["size_ratio"]
    assert 0.85 < ratio["median"] < 1.15
    with pytest.raises(Boom):
        packmesh.quality(m, size=lambda x, y, z: (_ for _ in ()).throw(Boom("in quality")))
