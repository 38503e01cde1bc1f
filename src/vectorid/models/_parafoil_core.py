"""Right-hand sides of the parafoil models: compiled kernel and a numpy reference version.

State vectors (SI units, angles in rad):

* 8-DoF (16 states): ``[N, E, D, phi, theta, psi, theta_r, psi_r, u, v, w, p, q, r,
  theta_r_dot, psi_r_dot]`` -- position of the payload joint J in NED, canopy Euler angles
  (3-2-1), payload relative pitch and yaw, inertial velocity of J in canopy axes, canopy body
  rates, payload relative rates;
* 6-DoF (12 states): ``[N, E, D, phi, theta, psi, u, v, w, p, q, r]`` -- the same with the
  payload locked to the canopy.

:func:`parafoil_rhs` is the compiled kernel (scalar code, no allocation, a work array per trial);
:func:`rhs_reference` is an independent numpy implementation of the same equations written in
matrix form (used by the tests to cross-check the kernel and by the benchmark as the
"what a user would write" baseline for ``scipy.integrate.solve_ivp``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from vectorid.models.parafoil_aero import (
    I_AERO,
    I_CDSP,
    I_CPS,
    I_CTH,
    I_IP,
    I_KPS,
    I_KTH,
    I_MAM,
    I_MC,
    I_MP,
    I_MRB,
    I_MUNK,
    I_RA,
    I_RMC,
    I_RP,
    I_S,
    canopy_aero,
    dcm_body_to_ned,
    euler_from_dcm,
    system_matrices,
)

NX8 = 16
NX6 = 12
NWORK = 192

_jit = nb.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")
_jit_inline = nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@_jit_inline
def solve_spd(a: np.ndarray, b: np.ndarray, n: int) -> bool:
    """Solve ``a[:n, :n] x = b[:n]`` in place by LDL^T; ``False`` if not positive definite.

    No square roots: the factorisation's critical path is one reciprocal per column. ``a``
    receives the unit lower factor below its diagonal and D on it. Inlined, so a constant
    ``n`` (the kernels' 8 or 6) gives loops with constant bounds.
    """
    for j in range(n):
        s = a[j, j]
        for m in range(j):
            s -= a[j, m] * a[j, m] * a[m, m]
        if not s > 0.0:
            return False
        a[j, j] = s
        r = 1.0 / s
        for i in range(j + 1, n):
            s = a[i, j]
            for m in range(j):
                s -= a[i, m] * a[j, m] * a[m, m]
            a[i, j] = s * r
    for i in range(n):
        s = b[i]
        for m in range(i):
            s -= a[i, m] * b[m]
        b[i] = s
    for i in range(n):
        b[i] /= a[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for m in range(i + 1, n):
            s -= a[m, i] * b[m]
        b[i] = s
    return True


@_jit_inline
def _solve8(a: np.ndarray, b: np.ndarray) -> bool:
    """``solve_spd(a, b, 8)`` (the 8-DoF kernel's solve)."""
    return solve_spd(a, b, 8)


@_jit_inline
def _solve6(a: np.ndarray, b: np.ndarray) -> bool:
    """``solve_spd(a, b, 6)`` (the rigid 6-DoF kernel's solve)."""
    return solve_spd(a, b, 6)


@_jit_inline
def parafoil_rhs(
    k: np.ndarray,
    x: np.ndarray,
    rho: float,
    g: float,
    wn: float,
    we: float,
    wd: float,
    dl: float,
    dr: float,
    rigid: bool,
    dx: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Time derivative of the parafoil state (compiled kernel).

    Parameters
    ----------
    k : ndarray, shape (NPROP,)
        Property row from :func:`vectorid.models.parafoil_aero.build_properties`.
    x : ndarray, shape (16,) or (12,)
        State (8-DoF or, with ``rigid``, 6-DoF layout).
    rho, g : float
        Air density (kg/m^3) and gravity (m/s^2) at the current altitude.
    wn, we, wd : float
        Wind (velocity of the air over ground) in NED, m/s.
    dl, dr : float
        Left and right flap commands (0 = none, 1 = full).
    rigid : bool
        ``True`` for the 6-DoF rigid model (payload locked to the canopy).
    dx : ndarray
        Receives the derivative (same layout as ``x``).
    work : ndarray, shape (NWORK,)
        Per-trial work array; on return ``work[106:109]`` = canopy airspeed (m/s), alpha and
        beta (rad) and ``work[109:112]`` = payload mass-centre offset from J (canopy axes, m).

    Returns
    -------
    bool
        ``False`` when the mass matrix was not positive definite (``dx`` is then NaN).
    """
    rmat = work[0:9].reshape((3, 3))
    mass = work[16:80].reshape((8, 8))
    vec = work[80:88]
    vel = work[88:96]
    wc = work[96:99]
    aux = work[100:180]
    phi, theta, psi = x[3], x[4], x[5]
    dcm_body_to_ned(phi, theta, psi, rmat)
    # for the Euler-angle rates (the compiler shares these with the inlined DCM)
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    if rigid:
        th_r = 0.0
        ps_r = 0.0
        for i in range(6):
            vel[i] = x[6 + i]
        vel[6] = 0.0
        vel[7] = 0.0
    else:
        th_r = x[6]
        ps_r = x[7]
        for i in range(8):
            vel[i] = x[8 + i]
    for i in range(3):
        wc[i] = rmat[0, i] * wn + rmat[1, i] * we + rmat[2, i] * wd
    system_matrices(
        k, rho, g * rmat[2, 0], g * rmat[2, 1], g * rmat[2, 2], th_r, ps_r, vel, wc, dl, dr,
        mass, vec, aux,
    )  # fmt: skip
    ok = _solve6(mass, vec) if rigid else _solve8(mass, vec)
    if not ok:
        for i in range(dx.shape[0]):
            dx[i] = np.nan
        return False
    u, v, w = vel[0], vel[1], vel[2]
    for i in range(3):
        dx[i] = rmat[i, 0] * u + rmat[i, 1] * v + rmat[i, 2] * w
    qr = vel[4] * sf + vel[5] * cf
    inv_ct = 1.0 / ct
    dx[3] = vel[3] + qr * st * inv_ct
    dx[4] = vel[4] * cf - vel[5] * sf
    dx[5] = qr * inv_ct
    if rigid:
        for i in range(6):
            dx[6 + i] = vec[i]
    else:
        dx[6] = vel[6]
        dx[7] = vel[7]
        for i in range(8):
            dx[8 + i] = vec[i]
    return True


@_jit
def parafoil_observe(
    k: np.ndarray,
    x: np.ndarray,
    wn: float,
    we: float,
    wd: float,
    rigid: bool,
    y: np.ndarray,
    work: np.ndarray,
) -> None:
    """Output channels of one trial (see ``Parafoil8DoF.outputs``).

    Channels 0..14 are the base channels: payload mass-centre position (NED, m) and inertial
    velocity (NED, m/s), canopy Euler angles (rad) and body rates (rad/s), canopy airspeed (m/s),
    angle of attack and sideslip of the canopy body axes (rad). For the 8-DoF model (``rigid``
    False) channels 15..22 follow: payload Euler angles (rad), payload body rates in payload axes
    (rad/s), relative pitch and yaw of the payload (rad).
    """
    rmat = work[0:9].reshape((3, 3))
    phi, theta, psi = x[3], x[4], x[5]
    dcm_body_to_ned(phi, theta, psi, rmat)
    if rigid:
        th_r = 0.0
        ps_r = 0.0
        vo = 6
        tdot = 0.0
        pdot = 0.0
    else:
        th_r = x[6]
        ps_r = x[7]
        vo = 8
        tdot = x[14]
        pdot = x[15]
    u, v, w = x[vo], x[vo + 1], x[vo + 2]
    p, q, r = x[vo + 3], x[vo + 4], x[vo + 5]
    cth, sth = math.cos(th_r), math.sin(th_r)
    cps, sps = math.cos(ps_r), math.sin(ps_r)
    px, py, pz = k[I_RP], k[I_RP + 1], k[I_RP + 2]
    # R_cp = Rz(ps_r) Ry(th_r)
    rx = cps * cth * px - sps * py + cps * sth * pz
    ry = sps * cth * px + cps * py + sps * sth * pz
    rz = -sth * px + cth * pz
    ox = p - tdot * sps
    oy = q + tdot * cps
    oz = r + pdot
    vx = u + oy * rz - oz * ry
    vy = v + oz * rx - ox * rz
    vz = w + ox * ry - oy * rx
    for i in range(3):
        y[i] = x[i] + rmat[i, 0] * rx + rmat[i, 1] * ry + rmat[i, 2] * rz
        y[3 + i] = rmat[i, 0] * vx + rmat[i, 1] * vy + rmat[i, 2] * vz
    y[6] = phi
    y[7] = theta
    y[8] = psi
    y[9] = p
    y[10] = q
    y[11] = r
    # canopy air data at the aerodynamic reference point
    rax, ray, raz = k[I_RA], k[I_RA + 1], k[I_RA + 2]
    wcx = rmat[0, 0] * wn + rmat[1, 0] * we + rmat[2, 0] * wd
    wcy = rmat[0, 1] * wn + rmat[1, 1] * we + rmat[2, 1] * wd
    wcz = rmat[0, 2] * wn + rmat[1, 2] * we + rmat[2, 2] * wd
    ua = u - wcx + q * raz - r * ray
    va = v - wcy + r * rax - p * raz
    wa = w - wcz + p * ray - q * rax
    vt = math.sqrt(ua * ua + va * va + wa * wa)
    y[12] = vt
    y[13] = math.atan2(wa, ua)
    y[14] = math.asin(min(1.0, max(-1.0, va / vt))) if vt > 0.0 else 0.0
    if rigid:
        return
    # payload attitude: R_ip = R_ic R_cp
    rp = work[9:18].reshape((3, 3))
    c00, c01, c02 = cps * cth, -sps, cps * sth
    c10, c11, c12 = sps * cth, cps, sps * sth
    c20, c21, c22 = -sth, 0.0, cth
    for i in range(3):
        rp[i, 0] = rmat[i, 0] * c00 + rmat[i, 1] * c10 + rmat[i, 2] * c20
        rp[i, 1] = rmat[i, 0] * c01 + rmat[i, 1] * c11 + rmat[i, 2] * c21
        rp[i, 2] = rmat[i, 0] * c02 + rmat[i, 1] * c12 + rmat[i, 2] * c22
    e = euler_from_dcm(rp)
    # keep the payload yaw continuous with the canopy yaw (no wrapping)
    pyaw = e[2] + 2.0 * math.pi * round((psi + ps_r - e[2]) / (2.0 * math.pi))
    y[15] = e[0]
    y[16] = e[1]
    y[17] = pyaw
    # payload body rates (payload axes): R_cp^T Omega
    y[18] = c00 * ox + c10 * oy + c20 * oz
    y[19] = c01 * ox + c11 * oy + c21 * oz
    y[20] = c02 * ox + c12 * oy + c22 * oz
    y[21] = th_r
    y[22] = ps_r


@_jit
def trim_glide(
    k: np.ndarray,
    rho: float,
    g: float,
    dl: float,
    dr: float,
    rigid: bool,
    x: np.ndarray,
    work: np.ndarray,
) -> bool:
    """Steady wings-level glide in calm air: solve for u, w, theta (and theta_r) in place.

    ``x`` holds the state to complete (position, roll and yaw are kept; the longitudinal
    unknowns are overwritten, all rates set to 0). Newton iteration with a finite-difference
    Jacobian on the accelerations du/dt, dw/dt, dq/dt (and the relative pitch acceleration).
    Returns ``False`` (leaving a wing-loading estimate in ``x``) when it does not converge.
    """
    n = x.shape[0]
    vo = 6 if rigid else 8
    m = 3 if rigid else 4
    for i in range(vo, n):
        x[i] = 0.0
    if not rigid:
        x[6] = 0.0
        x[7] = 0.0
    weight = (k[I_MC] + k[I_MP]) * g
    v0 = math.sqrt(2.0 * weight / (max(rho, 1e-6) * k[I_S] * 0.8))
    a0 = 0.3
    z = np.zeros(4)
    z[0] = v0 * math.cos(a0)
    z[1] = v0 * math.sin(a0)
    z[2] = -0.08
    z[3] = 0.08
    idx = np.zeros(4, dtype=np.int64)  # positions of the unknowns in x
    idx[0] = vo
    idx[1] = vo + 2
    idx[2] = 4
    idx[3] = 6
    res_i = np.zeros(4, dtype=np.int64)  # positions of the residuals in dx
    res_i[0] = vo
    res_i[1] = vo + 2
    res_i[2] = vo + 4
    res_i[3] = 14
    dx = np.zeros(n)
    f0 = np.zeros(4)
    jac = np.zeros((8, 8))
    step = np.zeros(8)
    ok = False
    for _ in range(60):
        for j in range(m):
            x[idx[j]] = z[j]
        if not parafoil_rhs(k, x, rho, g, 0.0, 0.0, 0.0, dl, dr, rigid, dx, work):
            break
        err = 0.0
        for j in range(m):
            f0[j] = dx[res_i[j]]
            err = max(err, abs(f0[j]))
        if not math.isfinite(err):
            break
        if err < 1e-10:
            ok = True
            break
        for c in range(m):
            h = 1e-6 * max(1.0, abs(z[c]))
            x[idx[c]] = z[c] + h
            parafoil_rhs(k, x, rho, g, 0.0, 0.0, 0.0, dl, dr, rigid, dx, work)
            for j in range(m):
                jac[j, c] = (dx[res_i[j]] - f0[j]) / h
            x[idx[c]] = z[c]
        # least-squares Newton step via normal equations (m <= 4): J^T J s = -J^T f
        ata = work[16:80].reshape((8, 8))
        for a in range(m):
            s = 0.0
            for j in range(m):
                s -= jac[j, a] * f0[j]
            step[a] = s
            for b in range(m):
                t = 0.0
                for j in range(m):
                    t += jac[j, a] * jac[j, b]
                ata[a, b] = t + (1e-12 if a == b else 0.0)
        if not solve_spd(ata, step, m):
            break
        # limit the step: speeds to 3 m/s, angles to 0.1 rad
        scale = 1.0
        for j in range(m):
            lim = 3.0 if j < 2 else 0.1
            if abs(step[j]) * scale > lim:
                scale = lim / abs(step[j])
        for j in range(m):
            z[j] += scale * step[j]
    if not ok:
        for j in range(m):
            x[idx[j]] = 0.0
        x[vo] = v0 * math.cos(a0)
        x[vo + 2] = v0 * math.sin(a0)
        x[4] = -0.08
        if not rigid:
            x[6] = 0.08
    return ok


# ---------------------------------------------------------------------------------------------
# numpy reference implementation (independent of the scalar kernels above)
# ---------------------------------------------------------------------------------------------


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def reference_matrices(
    k: np.ndarray,
    rho: float,
    g: float,
    x: np.ndarray,
    wind_ned: np.ndarray,
    dl: float,
    dr: float,
    rigid: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass matrix ``A``, right-hand side and body-to-NED rotation in matrix form (numpy).

    Written as ``A du/dt = J^T (F - Sigma A V)`` with explicit Jacobians ``J`` of the
    canopy (identity on its six speeds) and of the payload; see :func:`parafoil_rhs`.
    """
    k = np.asarray(k, dtype=float)
    x = np.asarray(x, dtype=float)
    if rigid:
        th_r = ps_r = 0.0
        speeds = np.concatenate([x[6:12], [0.0, 0.0]])
    else:
        th_r, ps_r = x[6], x[7]
        speeds = x[8:16].copy()
    phi, theta, psi = x[3:6]
    r_ib = _rot_z(psi) @ _rot_y(theta) @ _rot_x(phi)
    g_c = r_ib.T @ np.array([0.0, 0.0, g])
    w_c = r_ib.T @ np.asarray(wind_ned, dtype=float)
    v, om = speeds[:3], speeds[3:6]
    m_rb = k[I_MRB : I_MRB + 36].reshape(6, 6)
    m_am = rho * k[I_MAM : I_MAM + 36].reshape(6, 6)
    # canopy (Kirchhoff): A V' + Sigma A V = F, Sigma = [[om~, 0], [v~, om~]]
    v_rel = v - w_c
    h_rb = m_rb @ np.concatenate([v, om])
    h_am = m_am @ np.concatenate([v_rel, om])
    sig_rb = np.block([[_skew(om), np.zeros((3, 3))], [_skew(v), _skew(om)]])
    sig_am = np.block([[_skew(om), np.zeros((3, 3))], [_skew(v_rel), _skew(om)]])
    f_c = -sig_rb @ h_rb - sig_am @ h_am - m_am @ np.concatenate([np.cross(om, w_c), np.zeros(3)])
    if k[I_MUNK] != 0.0:
        f_c[3:] += np.cross(v_rel, m_am[:3, :3] @ v_rel)
    r_mc = k[I_RMC : I_RMC + 3]
    f_c[:3] += k[I_MC] * g_c
    f_c[3:] += np.cross(r_mc, k[I_MC] * g_c)
    r_a = k[I_RA : I_RA + 3]
    out = np.zeros(9)
    v_a = v_rel + np.cross(om, r_a)
    canopy_aero(k, rho, v_a[0], v_a[1], v_a[2], om[0], om[1], om[2], dl, dr, out)
    f_c[:3] += out[:3]
    f_c[3:] += np.cross(r_a, out[:3]) + out[3:6]
    a = np.zeros((8, 8))
    a[:6, :6] = m_rb + m_am
    q = np.zeros(8)
    q[:6] = f_c
    # payload: rho = R_cp r_p, Omega = om + th' e_theta + ps' e_z
    r_cp = _rot_z(ps_r) @ _rot_y(th_r)
    rho_c = r_cp @ k[I_RP : I_RP + 3]
    e_th = np.array([-math.sin(ps_r), math.cos(ps_r), 0.0])
    e_z = np.array([0.0, 0.0, 1.0])
    j_w = np.zeros((3, 8))
    j_w[:, 3:6] = np.eye(3)
    j_w[:, 6] = e_th
    j_w[:, 7] = e_z
    j_v = np.zeros((3, 8))
    j_v[:, :3] = np.eye(3)
    for col in range(3, 8):
        j_v[:, col] = np.cross(j_w[:, col], rho_c)
    big_om = j_w @ speeds
    v_p = j_v @ speeds
    # velocity-dependent accelerations (du/dt = 0)
    alpha0 = speeds[6] * speeds[7] * np.cross(e_z, e_th) + np.cross(om, big_om)
    a0 = np.cross(om, v) + np.cross(alpha0, rho_c) + np.cross(big_om, np.cross(big_om, rho_c))
    i_p = r_cp @ np.diag(k[I_IP : I_IP + 3]) @ r_cp.T
    m_p = k[I_MP]
    v_pr = v_p - w_c
    drag = -0.5 * rho * k[I_CDSP] * np.linalg.norm(v_pr) * v_pr * k[I_AERO]
    f_p = m_p * g_c + drag - m_p * a0
    t_p = -i_p @ alpha0 - np.cross(big_om, i_p @ big_om)
    a += m_p * j_v.T @ j_v + j_w.T @ i_p @ j_w
    q += j_v.T @ f_p + j_w.T @ t_p
    q[6] += -k[I_KTH] * th_r - k[I_CTH] * speeds[6]
    q[7] += -k[I_KPS] * ps_r - k[I_CPS] * speeds[7]
    return a, q, r_ib


def rhs_reference(
    t: float,
    x: np.ndarray,
    k: np.ndarray,
    rho: float,
    g: float,
    wind_ned: np.ndarray,
    dl: float,
    dr: float,
    rigid: bool = False,
) -> np.ndarray:
    """State derivative in plain numpy (same equations as :func:`parafoil_rhs`).

    Suitable for ``scipy.integrate.solve_ivp(lambda t, x: rhs_reference(t, x, ...), ...)``.
    ``t`` is unused (controls and air data are passed in), kept for the solve_ivp signature.
    """
    a, q, r_ib = reference_matrices(k, rho, g, x, wind_ned, dl, dr, rigid)
    n = 6 if rigid else 8
    acc = np.linalg.solve(a[:n, :n], q[:n])
    speeds = x[6:12] if rigid else x[8:16]
    phi, theta = x[3], x[4]
    p, q_, r = speeds[3:6]
    euler_dot = [
        p + (q_ * math.sin(phi) + r * math.cos(phi)) * math.tan(theta),
        q_ * math.cos(phi) - r * math.sin(phi),
        (q_ * math.sin(phi) + r * math.cos(phi)) / math.cos(theta),
    ]
    pos_dot = r_ib @ speeds[:3]
    if rigid:
        return np.concatenate([pos_dot, euler_dot, acc])
    return np.concatenate([pos_dot, euler_dot, speeds[6:8], acc])


def mechanical_energy(
    k: np.ndarray, rho: float, g: float, x: np.ndarray, rigid: bool = False
) -> float:
    """Kinetic (including apparent mass, calm air) + gravitational + joint-spring energy, J."""
    a, _, r_ib = reference_matrices(k, rho, g, x, np.zeros(3), 0.0, 0.0, rigid)
    if rigid:
        speeds = np.concatenate([x[6:12], [0.0, 0.0]])
        th_r = ps_r = 0.0
    else:
        speeds = x[8:16]
        th_r, ps_r = x[6], x[7]
    kin = 0.5 * speeds @ a @ speeds
    rho_c = _rot_z(ps_r) @ _rot_y(th_r) @ k[I_RP : I_RP + 3]
    z_mc = x[2] + (r_ib @ k[I_RMC : I_RMC + 3])[2]
    z_p = x[2] + (r_ib @ rho_c)[2]
    pot = -g * (k[I_MC] * z_mc + k[I_MP] * z_p)
    spring = 0.5 * k[I_KTH] * th_r**2 + 0.5 * k[I_KPS] * ps_r**2
    return float(kin + pot + spring)
