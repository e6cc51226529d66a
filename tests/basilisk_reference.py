"""Basilisk as an independent reference (optional: never a dependency of attitude).

Basilisk (``pip install bsk``) is imported only by the functions here, which the cross-check
tests and benchmarks call after ``pytest.importorskip("Basilisk")``: without it they skip.

:func:`rw_open_loop` runs Basilisk's spacecraft hub with its reaction-wheel state effector
(balanced wheels) under a motor-torque schedule held from one command time to the next, the
same model :class:`attitude.Spacecraft` integrates. Its integrator is Basilisk's default, one
RK4 step per dynamics task period; the commands are written to the wheels' command message
before the tick at which they take effect, so command k acts on [t_k, t_k + hold), as in
Basilisk's own scenarios (the wheel effector reads the message at the start of each tick,
before the hub integrates to the next one).
"""

from __future__ import annotations

import math

import numpy as np

NANO = 1_000_000_000
ST_BORESIGHT = (0.0, 0.6, 0.8)  # the star tracker's boresight in body axes (benchmarks/software.py)
ST_NOISE = (6.0, 45.0)  # its noise (arcsec, 1σ) across and about the boresight


def _nanos(t: float) -> int:
    return round(t * NANO)


def rw_open_loop(
    inertia,
    wheels,
    sigma0,
    omega0,
    hold: float,
    commands,
    dt: float,
    *,
    record_every: int = 1,
):
    """Basilisk's reaction-wheel effector under open-loop commands.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        Hub inertia about the centre of mass (kg m², wheels locked).
    wheels : list of dict
        Per wheel: ``axis``, ``Js`` and optionally ``Omega`` (rad/s), ``u_max``, ``u_min``,
        ``Omega_max`` (rad/s), ``P_max``, ``fCoulomb``, ``fStatic``, ``betaStatic``,
        ``cViscous``, ``omegaLimitCycle``.
    sigma0, omega0 : array_like, shape (3,)
        Initial MRP σ_BN and body rate ω_BN (rad/s).
    hold : float
        Command period (s); command k acts on [k hold, (k + 1) hold).
    commands : array_like, shape (K, n_wheels)
        Motor torques (N m).
    dt : float
        Dynamics task period (s): one RK4 step each; ``hold`` must be a multiple of it.

    Returns
    -------
    dict
        ``t`` (K + 1,), ``sigma`` (K + 1, 3), ``omega`` (K + 1, 3), ``Omega`` (K + 1, n), ``u``
        (K + 1, n) applied torques, at the command times (every ``record_every``-th).
    """
    from Basilisk.architecture import messaging
    from Basilisk.simulation import reactionWheelStateEffector, spacecraft
    from Basilisk.utilities import SimulationBaseClass

    commands = np.asarray(commands, dtype=np.float64)
    K, n = commands.shape
    steps = round(hold / dt)
    assert abs(steps * dt - hold) < 1e-12 * hold

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("dyn")
    proc.addTask(sim.CreateNewTask("task", _nanos(dt)))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    sc.hub.IHubPntBc_B = np.asarray(inertia, dtype=np.float64).tolist()
    sc.hub.mHub = 750.0
    sc.hub.sigma_BNInit = [[float(x)] for x in sigma0]
    sc.hub.omega_BN_BInit = [[float(x)] for x in omega0]
    rw = reactionWheelStateEffector.ReactionWheelStateEffector()
    rw.ModelTag = "rw"
    keep = []
    for i, w in enumerate(wheels):
        c = reactionWheelStateEffector.RWConfigPayload()
        c.gsHat_B = [[float(x)] for x in w["axis"]]
        c.Js = float(w["Js"])
        c.Jt = 0.5 * c.Js
        c.Jg = 0.5 * c.Js
        c.Omega = float(w.get("Omega", 0.0))
        c.Omega_max = float(w.get("Omega_max", -1.0))
        c.u_max = float(w.get("u_max", -1.0))
        c.u_min = float(w.get("u_min", 0.0))
        c.P_max = float(w.get("P_max", -1.0))
        c.fCoulomb = float(w.get("fCoulomb", 0.0))
        c.fStatic = float(w.get("fStatic", 0.0))
        c.betaStatic = float(w.get("betaStatic", -1.0))
        c.cViscous = float(w.get("cViscous", 0.0))
        c.omegaLimitCycle = float(w.get("omegaLimitCycle", 1e-4))
        c.rWB_B = [[0.0], [0.0], [0.0]]
        c.mass = 1.0
        c.RWModel = messaging.BalancedWheels
        c.label = f"RW{i + 1}"
        rw.addReactionWheel(c)
        keep.append(c)
    sc.addStateEffector(rw)
    sim.AddModelToTask("task", rw, 2)
    sim.AddModelToTask("task", sc, 1)
    msg = messaging.ArrayMotorTorqueMsg()
    payload = messaging.ArrayMotorTorqueMsgPayload()
    payload.motorTorque = [0.0] * n
    msg.write(payload)
    rw.rwMotorCmdInMsg.subscribeTo(msg)
    state_log = sc.scStateOutMsg.recorder(_nanos(hold * record_every))
    speed_log = rw.rwSpeedOutMsg.recorder(_nanos(hold * record_every))
    rw_logs = [rw.rwOutMsgs[i].recorder(_nanos(hold * record_every)) for i in range(n)]
    sim.AddModelToTask("task", state_log)
    sim.AddModelToTask("task", speed_log)
    for lg in rw_logs:
        sim.AddModelToTask("task", lg)
    sim.InitializeSimulation()
    for k in range(K):
        payload.motorTorque = [float(x) for x in commands[k]] + [0.0] * 0
        msg.write(payload, _nanos(k * hold))
        sim.ConfigureStopTime(_nanos((k + 1) * hold))
        sim.ExecuteSimulation()
    t = state_log.times() * 1e-9
    u = np.stack([lg.u_current for lg in rw_logs], axis=1)
    return {
        "t": t,
        "sigma": np.array(state_log.sigma_BN),
        "omega": np.array(state_log.omega_BN_B),
        "Omega": np.array(speed_log.wheelSpeeds)[:, :n],
        "u": u,
    }


def mrp_to_quaternion(sigma):
    """The attitude quaternion (attitude's convention: body to space) of MRPs σ_BN."""
    s = np.asarray(sigma, dtype=np.float64)
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    q0 = (1.0 - s2) / (1.0 + s2)
    qv = 2.0 * s / (1.0 + s2)
    return np.concatenate([q0, qv], axis=-1)


def rw_feedback_scenario(
    dt: float = 0.1,
    duration: float = 600.0,
    record_every: int = 1,
    dyn_dt: float | None = None,
    sensors: bool = False,
    estimator: bool = False,
    *,
    ukf_task: str = "st",
):
    """Basilisk's ``scenarioAttitudeFeedbackRW`` (balanced wheels, no voltage interface):
    a 900/800/600 kg m² hub, three Honeywell HR16 wheels (50 N m s) on the body axes at 100,
    200 and 300 rpm, inertial pointing (``inertial3D``, σ_R0N = 0) with ``attTrackingError``,
    ``mrpFeedback`` (K = 3.5, P = 30, no integral term) and ``rwMotorTorque`` on the three
    axes, truth navigation (``simpleNav``), σ_BN(0) = (0.1, 0.2, −0.3), ω(0) = (0.001, −0.01,
    0.03) rad/s, everything at the task period ``dt`` (0.1 s in the scenario), the hub
    integrated by RK4 at that period (or, with ``dyn_dt``, the dynamics and the wheels in a
    task of that period and the flight software in one of period ``dt``: the same closed loop,
    a finer integration).

    With ``sensors``, Basilisk's gyro (``imuSensor`` at the tick: white rate noise of
    0.05°/√h ARW, a 3°/h bias) and its star tracker (``starTracker`` in a 2 Hz task: white
    noise, the error rotation 6″ across and 45″ about the boresight ``ST_BORESIGHT``, ours)
    are run. Both error models are Basilisk's Gauss–Markov processes with their propagation
    matrix set to zero, so the noise is white; Basilisk's default, the identity, makes it a
    random walk (bounded by the walk bounds). Without ``estimator`` the loop stays on the
    truth navigation and nothing reads the sensors: for timing their cost.

    With ``estimator`` (needs ``sensors``), Basilisk's attitude filter closes the loop:
    ``stComm`` turns the star tracker's ``STSensorMsg`` into an ``STAttMsg`` (case frame = body
    frame) and ``inertialUKF`` runs after it in the 2 Hz task. That filter is a square-root UKF
    of (σ_BN, ω_BN) whose dynamics model is σ̇ = ¼ B(σ) ω, ω̇ = I⁻¹ τ, with τ the wheels'
    reaction torque from the change of the wheel speeds since its previous call, one Euler step
    from one measurement time to the next. It updates with the star tracker (its noise matrix
    is the tracker's covariance in MRP, δσ = δθ/4) and reads the wheel speeds and
    configuration and the mass properties. ``attTrackingError`` reads its ``navStateOutMsg``
    in place of ``simpleNav``'s, and ``simpleNav`` is not run.

    The gyro: no Basilisk module writes the ``AccDataMsg`` buffer that the filter's
    ``gyrBuffInMsg`` reads (only ``inertialUKF`` and ``dvAccumulation`` read that type;
    ``imuSensor`` writes ``IMUSensorMsg``, ``imuComm`` ``IMUSensorBodyMsg``), and writing one
    from the gyro's output every tick would put Python in Basilisk's loop. So that input is a
    zero buffer written once. The filter reads its buffer only on a call without a fresh star
    tracker measurement: then it turns σ by the buffer's rotations since its last output (none
    here) and outputs the low-pass filtered gyro rate as ω (zero here). At the tracker's rate
    every call has a fresh measurement, so the output is always the filter's own (σ̂, ω̂) and
    that branch never runs. The gyro still runs at the tick, for its cost, but nothing reads
    it. With ``ukf_task="t"`` the filter runs at the 10 Hz tick instead, as a filter with a
    gyro would. On four ticks in five it then takes that branch: σ is held and ω = 0. The loop
    then has a fifth of its damping: it converges in about an hour instead of about 20
    minutes, and its pointing error is 29″ RMS over the second hour, against 6″.

    Timing: at t = 0.5 k the 2 Hz task runs after the 10 Hz one. The star tracker samples the
    state at t, the filter updates, and the control acts on that estimate from t + 0.1 s,
    held until the next one. The filter discards the message of t = 0, whose write time it
    stored at reset. So its first output is at 0.5 s, and for the first six ticks the control
    reads an unwritten navigation message (zeros: no torque). Basilisk prints "unwritten
    message" errors for these reads.

    The filter's settings (α = 0.02, β = 2, κ = 0, switchMag = 1.2, the initial covariance
    diag(0.04 ×3, 0.004 ×3), the process noise diag(0.0017² ×3, 0.00017² ×3) and the low-pass
    filter) are those of Basilisk's unit test
    (src/fswAlgorithms/attDetermination/InertialUKF/_UnitTest/test_inertialKF.py,
    ``setupFilterData``; also the module's user guide). Only the star tracker noise is
    changed, to this tracker's instead of the test's 0.00017². Initial state: the true σ(0)
    and ω(0) with that wide covariance, so the first update takes the first measurement
    almost wholly. That is the closest equivalent of our MEKF, which starts from the first star
    tracker measurement and reads the rate from its gyro. With the test's process noise the
    filter follows its measurements: its attitude error is the tracker's (≈ 46″ RMS), and the
    loop's low bandwidth averages it down to ≈ 6″ of pointing error.

    Returns
    -------
    dict
        At every ``record_every``-th tick: ``t``, ``sigma``, ``omega``, ``Omega`` (wheel
        speeds), ``u`` (the motor torques commanded at the tick), ``Lr`` (the torque request);
        with ``estimator``, ``sigma_est`` and ``omega_est`` (the filter's navigation output read
        at the tick).
    """
    if estimator and not sensors:
        raise ValueError("estimator=True needs sensors=True (the filter reads the star tracker)")
    if ukf_task not in ("st", "t"):
        raise ValueError(f"ukf_task must be 'st' (2 Hz) or 't' (the tick), not {ukf_task!r}")
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import attTrackingError, inertial3D, mrpFeedback, rwMotorTorque
    from Basilisk.simulation import reactionWheelStateEffector, simpleNav, spacecraft
    from Basilisk.utilities import SimulationBaseClass, simIncludeRW

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("p")
    step = _nanos(dt)
    dyn = "t" if dyn_dt is None else "d"
    if dyn_dt is not None:  # the dynamics task first (higher priority)
        proc.addTask(sim.CreateNewTask("d", _nanos(dyn_dt)), 10)
    proc.addTask(sim.CreateNewTask("t", step))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    inertia = [900.0, 0.0, 0.0, 0.0, 800.0, 0.0, 0.0, 0.0, 600.0]
    sc.hub.mHub = 750.0
    sc.hub.IHubPntBc_B = [[900.0, 0.0, 0.0], [0.0, 800.0, 0.0], [0.0, 0.0, 600.0]]
    sc.hub.sigma_BNInit = [[0.1], [0.2], [-0.3]]
    sc.hub.omega_BN_BInit = [[0.001], [-0.01], [0.03]]
    sim.AddModelToTask(dyn, sc, 1)
    factory = simIncludeRW.rwFactory()
    for axis, rpm in (([1, 0, 0], 100.0), ([0, 1, 0], 200.0), ([0, 0, 1], 300.0)):
        factory.create("Honeywell_HR16", axis, maxMomentum=50.0, Omega=rpm,
                       RWModel=messaging.BalancedWheels)  # fmt: skip
    rw = reactionWheelStateEffector.ReactionWheelStateEffector()
    rw.ModelTag = "rw"
    factory.addToSpacecraft(rw.ModelTag, rw, sc)
    sim.AddModelToTask(dyn, rw, 2)
    nav = simpleNav.SimpleNav()
    nav.ModelTag = "nav"
    if not estimator:
        sim.AddModelToTask("t", nav)
    ref = inertial3D.inertial3D()
    ref.ModelTag = "ref"
    ref.sigma_R0N = [0.0, 0.0, 0.0]
    sim.AddModelToTask("t", ref)
    err = attTrackingError.attTrackingError()
    err.ModelTag = "err"
    sim.AddModelToTask("t", err)
    ctl = mrpFeedback.mrpFeedback()
    ctl.ModelTag = "ctl"
    ctl.K = 3.5
    ctl.Ki = -1.0
    ctl.P = 30.0
    ctl.integralLimit = 2.0 / ctl.Ki * 0.1
    sim.AddModelToTask("t", ctl)
    alloc = rwMotorTorque.rwMotorTorque()
    alloc.ModelTag = "alloc"
    alloc.controlAxes_B = [1, 0, 0, 0, 1, 0, 0, 0, 1]
    sim.AddModelToTask("t", alloc)
    vc = messaging.VehicleConfigMsg().write(messaging.VehicleConfigMsgPayload(ISCPntB_B=inertia))
    rw_params = factory.getConfigMessage()
    nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    err.attRefInMsg.subscribeTo(ref.attRefOutMsg)
    ctl.guidInMsg.subscribeTo(err.attGuidOutMsg)
    ctl.vehConfigInMsg.subscribeTo(vc)
    ctl.rwParamsInMsg.subscribeTo(rw_params)
    ctl.rwSpeedsInMsg.subscribeTo(rw.rwSpeedOutMsg)
    alloc.rwParamsInMsg.subscribeTo(rw_params)
    alloc.vehControlInMsg.subscribeTo(ctl.cmdTorqueOutMsg)
    rw.rwMotorCmdInMsg.subscribeTo(alloc.rwMotorTorqueOutMsg)
    if sensors:
        from Basilisk.simulation import imuSensor, starTracker

        imu = imuSensor.ImuSensor()
        imu.ModelTag = "imu"
        imu.setBodyToPlatformDCM(0.0, 0.0, 0.0)
        arw = math.radians(0.05) / 60.0  # rad/√s
        imu.PMatrixGyro = np.eye(3) * (arw / math.sqrt(dt))
        imu.setAMatrixGyro(np.zeros((3, 3)))
        imu.setErrorBoundsGyro(np.array([1e-3] * 3))
        imu.senRotBias = np.radians([3.0, -2.0, 1.5]) / 3600.0
        imu.scStateInMsg.subscribeTo(sc.scStateOutMsg)
        sim.AddModelToTask("t", imu)
        proc.addTask(sim.CreateNewTask("st", _nanos(0.5)))
        st = starTracker.StarTracker()
        st.ModelTag = "st"
        # The error rotation vector (body axes) has the covariance σc² (1 − b bᵀ) + σb² b bᵀ
        # about the boresight b, as ours; PMatrix is its square root.
        arcsec = math.radians(1.0 / 3600.0)
        b = np.array(ST_BORESIGHT)
        bb = np.outer(b, b)
        st_sqrt = ST_NOISE[0] * arcsec * (np.eye(3) - bb) + ST_NOISE[1] * arcsec * bb
        st.PMatrix = st_sqrt
        st.setAMatrix(np.zeros((3, 3)))
        st.setWalkBounds(np.array([1e-2] * 3))
        st.scStateInMsg.subscribeTo(sc.scStateOutMsg)
        sim.AddModelToTask("st", st)
    if estimator:
        from Basilisk.fswAlgorithms import inertialUKF, stComm

        stc = stComm.stComm()
        stc.ModelTag = "stComm"
        stc.dcm_BP = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]  # case frame = body frame
        stc.stSensorInMsg.subscribeTo(st.sensorOutMsg)
        sim.AddModelToTask("st", stc)
        ukf = inertialUKF.inertialUKF()
        ukf.ModelTag = "ukf"
        # Settings of Basilisk's unit test (src/fswAlgorithms/attDetermination/InertialUKF/
        # _UnitTest/test_inertialKF.py, setupFilterData), the star tracker's noise ours.
        ukf.alpha = 0.02
        ukf.beta = 2.0
        ukf.kappa = 0.0
        ukf.switchMag = 1.2
        std = inertialUKF.STMessage()
        std.noise = (st_sqrt @ st_sqrt / 16.0).ravel().tolist()  # MRP: δσ = δθ/4
        ukf.STDatasStruct.STMessages = [std]
        ukf.STDatasStruct.numST = 1
        ukf.stateInit = [0.1, 0.2, -0.3, 0.001, -0.01, 0.03]
        ukf.covarInit = np.diag([0.04] * 3 + [0.004] * 3).ravel().tolist()
        ukf.qNoise = np.diag([0.0017**2] * 3 + [0.00017**2] * 3).ravel().tolist()
        lp = inertialUKF.LowPassFilterData()
        lp.hStep = 0.5
        lp.omegCutoff = 15.0 / (2.0 * math.pi)
        ukf.gyroFilt = [lp, lp, lp]
        ukf.STDatasStruct.STMessages[0].stInMsg.subscribeTo(stc.stAttOutMsg)
        ukf.massPropsInMsg.subscribeTo(vc)
        ukf.rwParamsInMsg.subscribeTo(rw_params)
        ukf.rwSpeedsInMsg.subscribeTo(rw.rwSpeedOutMsg)
        gyro_buffer = messaging.AccDataMsg().write(messaging.AccDataMsgPayload())
        ukf.gyrBuffInMsg.subscribeTo(gyro_buffer)
        sim.AddModelToTask(ukf_task, ukf, 0 if ukf_task == "t" else -1)
        err.attNavInMsg.subscribeTo(ukf.navStateOutMsg)
    else:
        err.attNavInMsg.subscribeTo(nav.attOutMsg)
    every = step * record_every
    logs = {
        "state": sc.scStateOutMsg.recorder(every),
        "speed": rw.rwSpeedOutMsg.recorder(every),
        "motor": alloc.rwMotorTorqueOutMsg.recorder(every),
        "lr": ctl.cmdTorqueOutMsg.recorder(every),
    }
    if estimator:
        logs["nav"] = ukf.navStateOutMsg.recorder(every)
    for lg in logs.values():
        sim.AddModelToTask("t", lg)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(_nanos(duration))
    sim.ExecuteSimulation()
    out = {}
    if estimator:
        out["sigma_est"] = np.array(logs["nav"].sigma_BN)
        out["omega_est"] = np.array(logs["nav"].omega_BN_B)
    return out | {
        "t": logs["state"].times() * 1e-9,
        "sigma": np.array(logs["state"].sigma_BN),
        "omega": np.array(logs["state"].omega_BN_B),
        "Omega": np.array(logs["speed"].wheelSpeeds)[:, :3],
        "u": np.array(logs["motor"].motorTorque)[:, :3],
        "Lr": np.array(logs["lr"].torqueRequestBody),
    }
