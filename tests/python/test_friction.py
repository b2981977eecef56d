"""Coulomb friction through fmpy (issue 32): a 2 kg block on a horizontal prismatic joint
with `<dynamics friction="3"/>`, built from its URDF with `mbfmu build --urdf` (the
runtime), launched at 2 m/s and pushed along its motion by 1 N < 3 N. Closed form: it
slows at (1 − 3)/2 = −1 m/s², comes to rest at t = 2 s, q = 2 m, and stays there with the
friction force −1 N holding it. In every interface: FMI 2.0 Co-Simulation (the event
located inside doStep), FMI 2.0 Model Exchange (fmpy's CVODE locates the state event,
fmi2NewDiscreteStates puts the joint at rest) and FMI 3.0 Co-Simulation. A block pushed by
5 N > 3 N from rest slips at (5 − 3)/2 = 1 m/s².
"""

from __future__ import annotations

import subprocess

import fmpy
import numpy as np
import pytest

from test_linearization import cli
from test_urdf_fmu import build_env

MASS, FRICTION = 2.0, 3.0

BLOCK = f"""<robot name="friction_block">
  <link name="base"/>
  <link name="block"><inertial><mass value="{MASS}"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="slide" type="prismatic"><parent link="base"/><child link="block"/>
    <axis xyz="1 0 0"/><limit lower="-10" upper="10" effort="100" velocity="10"/>
    <dynamics friction="{FRICTION}"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("friction")
    urdf = out / "friction_block.urdf"
    urdf.write_text(BLOCK)
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out),
                          "--name", "FrictionBlock", "--platforms", "host"],
                         capture_output=True, text=True, env=build_env())
    assert res.returncode == 0, res.stderr
    assert "Coulomb friction" not in res.stderr, res.stderr
    return out / "FrictionBlock.fmu", out.parent / (out.name + "3") / "FrictionBlock.fmu"


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange", "FMI3"])
def test_a_sliding_block_comes_to_rest_and_stays_in_every_interface(fmus, interface):
    fmi2, fmi3 = fmus
    path = fmi3 if interface == "FMI3" else fmi2
    kind = "CoSimulation" if interface == "FMI3" else interface
    res = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=4.0, output_interval=0.05,
                            relative_tolerance=1e-9,
                            start_values={"tau_slide": 1.0, "slide_dot": 2.0},
                            output=["slide", "slide_dot", "tau_friction_slide"])
    t = res["time"]
    slipping = t < 2.0 - 1e-6
    at_rest = t > 2.0 + 1e-6
    print(f"{interface}: at rest at {res['slide'][-1]!r}, q̇ {res['slide_dot'][-1]!r}, "
          f"friction {res['tau_friction_slide'][-1]!r}")
    # While it slips: the closed form to the integration's accuracy.
    assert np.allclose(res["slide"][slipping], 2 * t[slipping] - t[slipping] ** 2 / 2, atol=1e-7)
    assert (res["tau_friction_slide"][slipping] == -FRICTION).all()
    # At rest: on the spot where the closed form stops, exactly still, held by −1 N.
    assert np.abs(res["slide"][at_rest] - 2.0).max() < 1e-7
    assert (res["slide_dot"][at_rest] == 0.0).all()
    assert np.ptp(res["slide"][at_rest]) == 0.0
    assert np.allclose(res["tau_friction_slide"][at_rest], -1.0, rtol=1e-12)


def test_pushed_harder_than_its_friction_the_block_slips(fmus):
    fmi2, _ = fmus
    res = fmpy.simulate_fmu(str(fmi2), stop_time=2.0, output_interval=0.1,
                            start_values={"tau_slide": 5.0},
                            output=["slide", "slide_dot", "tau_friction_slide"])
    t = res["time"]
    a = (5.0 - FRICTION) / MASS
    assert np.allclose(res["slide"], 0.5 * a * t**2, atol=1e-9)
    assert (res["tau_friction_slide"][1:] == -FRICTION).all()


def test_a_negative_friction_is_refused_with_one_line(tmp_path):
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(BLOCK.replace(f'friction="{FRICTION}"', 'friction="-1"'))
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(tmp_path),
                          "--platforms", "host"], capture_output=True, text=True, env=build_env())
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 1 and len(lines) == 1 and lines[0].startswith("mbfmu: "), res.stderr
    assert "friction" in lines[0], lines
    assert not list(tmp_path.glob("*.fmu"))
