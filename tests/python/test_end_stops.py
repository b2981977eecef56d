"""End stops through fmpy (issue 32): a URDF pendulum built with `mbfmu build --urdf`
(the runtime) falls from the middle of its limits onto its lower stop and rests there, in
every interface: FMI 2.0 Co-Simulation (the event located inside doStep), FMI 2.0 Model
Exchange (fmpy's CVODE locates the state event, fmi2NewDiscreteStates applies the impact)
and FMI 3.0 Co-Simulation. Closed forms: the bob rests at the stop (q = 0.5 rad, q̇ = 0)
with the reaction m g l sin 0.5, and E = −m g l cos 0.5 after the inelastic impact; with
restitution 1 the energy is kept across the bounces.
"""

from __future__ import annotations

import subprocess

import fmpy
import numpy as np
import pytest

from test_linearization import cli
from test_urdf_fmu import build_env

G, M, L, STOP = 9.81, 2.0, 0.8, 0.5

PENDULUM = f"""<robot name="stop_pendulum">
  <link name="base"/>
  <link name="bob"><inertial><origin xyz="0 0 -{L}"/><mass value="{M}"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <joint name="swing" type="revolute"><parent link="base"/><child link="bob"/>
    <axis xyz="0 1 0"/><limit lower="{STOP}" upper="2.0" effort="100" velocity="10"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("end_stops")
    urdf = out / "stop_pendulum.urdf"
    urdf.write_text(PENDULUM)
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out),
                          "--name", "StopPendulum", "--platforms", "host"],
                         capture_output=True, text=True, env=build_env())
    assert res.returncode == 0, res.stderr
    return out / "StopPendulum.fmu", out.parent / (out.name + "3") / "StopPendulum.fmu"


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange", "FMI3"])
def test_the_pendulum_rests_on_its_stop_in_every_interface(fmus, interface):
    fmi2, fmi3 = fmus
    path = fmi3 if interface == "FMI3" else fmi2
    kind = "CoSimulation" if interface == "FMI3" else interface
    res = fmpy.simulate_fmu(str(path), fmi_type=kind, stop_time=3.0, output_interval=0.01,
                            relative_tolerance=1e-8, start_values={"tau_swing": 0.0},
                            output=["swing", "swing_dot", "E", "tau_stop_swing"])
    start = res["swing"][0]
    assert STOP < start < 2.0
    end = res[-1]
    hold = M * G * L * np.sin(STOP)
    print(f"{interface}: rests at {end['swing']!r}, q̇ {end['swing_dot']!r}, reaction {end['tau_stop_swing']!r} (m g l sin θ = {hold!r})")
    # The impact puts it on the stop exactly; resting keeps it there to the last bit in
    # Co-Simulation; CVODE integrates der = 0 from the state fmi2NewDiscreteStates set.
    assert abs(end["swing"] - STOP) < 1e-12 and abs(end["swing_dot"]) < 1e-12, end
    assert end["tau_stop_swing"] == pytest.approx(hold, rel=1e-9)
    assert end["E"] == pytest.approx(-M * G * L * np.cos(STOP), rel=1e-12)
    assert (res["swing"] >= STOP - 1e-12).all()


def test_an_elastic_stop_keeps_the_energy(fmus):
    fmi2, _ = fmus
    res = fmpy.simulate_fmu(str(fmi2), stop_time=3.0, output_interval=0.01, relative_tolerance=1e-10,
                            start_values={"tau_swing": 0.0, "restitution": 1.0},
                            output=["swing", "swing_dot", "E"])
    e0 = res["E"][0]
    bounces = int(np.sum(np.diff(np.sign(res["swing_dot"])) > 0))
    print(f"elastic: {bounces} bounces, E drift {np.abs(res['E'] - e0).max() / abs(e0):.2e}")
    assert bounces >= 2
    assert np.abs(res["E"] - e0).max() < 1e-8 * abs(e0)
    assert (res["swing"] >= STOP - 1e-12).all()
