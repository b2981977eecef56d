//! 3-D spatial algebra on small arrays of a [`Scalar`], written by hand (Featherstone,
//! *Rigid Body Dynamics Algorithms*, 2008, chapter 2).
//!
//! Conventions:
//! - a spatial motion vector ([`Motion`]) is `(angular, linear)` = `(ω, v_O)`: the angular
//!   velocity and the velocity of the body-fixed point at the frame's origin O, both in the
//!   frame's axes; a spatial force ([`Force`]) is `(moment about O, force)`;
//! - a [`Transform`] `B_X_A` (frame A to frame B) holds `E`, the rotation taking A-coordinates
//!   to B-coordinates, and `r`, the position of B's origin in A-coordinates:
//!   `X m = (E ω, E (v − r × ω))`, and for forces `X* f = (E (n − r × f), E f)`;
//! - rotations are 3×3 arrays, row-major, `m[row][col]`.
//!
//! Nothing here compares scalar values or branches on them, so the same code runs in `f64`,
//! in dual numbers and in a tracing scalar (`Expr`).

use crate::model::Scalar;

pub type V3<S> = [S; 3];
pub type M3<S> = [[S; 3]; 3];

pub fn zero3<S: Scalar>() -> V3<S> {
    [S::zero(); 3]
}

pub fn zero33<S: Scalar>() -> M3<S> {
    [[S::zero(); 3]; 3]
}

/// An `f64` vector as scalars.
pub fn lift3<S: Scalar>(v: &V3<f64>) -> V3<S> {
    [S::from(v[0]), S::from(v[1]), S::from(v[2])]
}

/// An `f64` matrix as scalars.
pub fn lift33<S: Scalar>(m: &M3<f64>) -> M3<S> {
    [lift3(&m[0]), lift3(&m[1]), lift3(&m[2])]
}

pub fn add<S: Scalar>(a: &V3<S>, b: &V3<S>) -> V3<S> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub<S: Scalar>(a: &V3<S>, b: &V3<S>) -> V3<S> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale<S: Scalar>(a: &V3<S>, s: S) -> V3<S> {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn dot<S: Scalar>(a: &V3<S>, b: &V3<S>) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross<S: Scalar>(a: &V3<S>, b: &V3<S>) -> V3<S> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `m v`.
pub fn mat_vec<S: Scalar>(m: &M3<S>, v: &V3<S>) -> V3<S> {
    [dot(&m[0], v), dot(&m[1], v), dot(&m[2], v)]
}

/// `mᵀ v`.
pub fn mat_t_vec<S: Scalar>(m: &M3<S>, v: &V3<S>) -> V3<S> {
    [
        m[0][0] * v[0] + m[1][0] * v[1] + m[2][0] * v[2],
        m[0][1] * v[0] + m[1][1] * v[1] + m[2][1] * v[2],
        m[0][2] * v[0] + m[1][2] * v[1] + m[2][2] * v[2],
    ]
}

/// `a b`.
pub fn mat_mul<S: Scalar>(a: &M3<S>, b: &M3<S>) -> M3<S> {
    let mut c = zero33();
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}

pub fn transpose<S: Scalar>(m: &M3<S>) -> M3<S> {
    let mut t = zero33();
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = m[j][i];
        }
    }
    t
}

pub fn mat_add<S: Scalar>(a: &M3<S>, b: &M3<S>) -> M3<S> {
    let mut c = *a;
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] += b[i][j];
        }
    }
    c
}

pub fn mat_sub<S: Scalar>(a: &M3<S>, b: &M3<S>) -> M3<S> {
    let mut c = *a;
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] -= b[i][j];
        }
    }
    c
}

/// `a bᵀ` (outer product), times `s`.
pub fn outer<S: Scalar>(a: &V3<S>, b: &V3<S>, s: S) -> M3<S> {
    let mut c = zero33();
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i] * b[j] * s;
        }
    }
    c
}

/// The cross-product matrix: `skew(r) v = r × v`.
pub fn skew<S: Scalar>(r: &V3<S>) -> M3<S> {
    let z = S::zero();
    [[z, -r[2], r[1]], [r[2], z, -r[0]], [-r[1], r[0], z]]
}

/// The rotation by `angle` about the unit `axis` (Rodrigues: `I + sin θ [a]× + (1 − cos θ)
/// [a]×²`), taking coordinates in the rotated frame to the fixed one.
pub fn axis_angle<S: Scalar>(axis: &V3<f64>, angle: S) -> M3<S> {
    let (s, c) = (angle.sin(), angle.cos());
    let k = S::one() - c;
    let [x, y, z] = *axis;
    // About a coordinate axis its diagonal entry is exactly 1 (a tracing scalar cannot
    // see that c + (1 − c) is): a test of the constant axis, not of a scalar value.
    let diag = |aa: f64| if aa == 1.0 { S::one() } else { c + k * aa };
    [
        [diag(x * x), k * (x * y) - s * z, k * (x * z) + s * y],
        [k * (x * y) + s * z, diag(y * y), k * (y * z) - s * x],
        [k * (x * z) - s * y, k * (y * z) + s * x, diag(z * z)],
    ]
}

/// Hamilton product `a ⊗ b` of quaternions `(w, x, y, z)`.
pub fn quat_mul<S: Scalar>(a: &[S; 4], b: &[S; 4]) -> [S; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

/// The rotation matrix of a quaternion `(w, x, y, z)` of any non-zero norm: the
/// homogeneous form divided by |q|², orthogonal in exact arithmetic whatever the norm (so
/// an integrator's drift off the unit sphere does not shear the body).
pub fn quat_to_matrix<S: Scalar>(q: &[S; 4]) -> M3<S> {
    let [w, x, y, z] = *q;
    let s = (w * w + x * x + y * y + z * z).recip();
    let two = s * 2.0;
    [
        [
            (w * w + x * x - y * y - z * z) * s,
            (x * y - w * z) * two,
            (x * z + w * y) * two,
        ],
        [
            (x * y + w * z) * two,
            (w * w - x * x + y * y - z * z) * s,
            (y * z - w * x) * two,
        ],
        [
            (x * z - w * y) * two,
            (y * z + w * x) * two,
            (w * w - x * x - y * y + z * z) * s,
        ],
    ]
}

/// The unit quaternion `(w, x, y, z)` of a rotation matrix (Shepperd's method: it picks the
/// largest of four candidates, so it branches on values and is for `f64` constants only).
pub fn quat_from_matrix(m: &M3<f64>) -> [f64; 4] {
    let t = m[0][0] + m[1][1] + m[2][2];
    let q = if t >= m[0][0].max(m[1][1]).max(m[2][2]) {
        let w = (1.0 + t).sqrt() * 0.5;
        let k = 0.25 / w;
        [
            w,
            (m[2][1] - m[1][2]) * k,
            (m[0][2] - m[2][0]) * k,
            (m[1][0] - m[0][1]) * k,
        ]
    } else if m[0][0] >= m[1][1] && m[0][0] >= m[2][2] {
        let x = (1.0 + 2.0 * m[0][0] - t).sqrt() * 0.5;
        let k = 0.25 / x;
        [
            (m[2][1] - m[1][2]) * k,
            x,
            (m[0][1] + m[1][0]) * k,
            (m[0][2] + m[2][0]) * k,
        ]
    } else if m[1][1] >= m[2][2] {
        let y = (1.0 + 2.0 * m[1][1] - t).sqrt() * 0.5;
        let k = 0.25 / y;
        [
            (m[0][2] - m[2][0]) * k,
            (m[0][1] + m[1][0]) * k,
            y,
            (m[1][2] + m[2][1]) * k,
        ]
    } else {
        let z = (1.0 + 2.0 * m[2][2] - t).sqrt() * 0.5;
        let k = 0.25 / z;
        [
            (m[1][0] - m[0][1]) * k,
            (m[0][2] + m[2][0]) * k,
            (m[1][2] + m[2][1]) * k,
            z,
        ]
    };
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
}

/// A spatial motion vector `(ω, v_O)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion<S> {
    pub ang: V3<S>,
    pub lin: V3<S>,
}

/// A spatial force vector `(n_O, f)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Force<S> {
    pub ang: V3<S>,
    pub lin: V3<S>,
}

impl<S: Scalar> Motion<S> {
    pub fn zero() -> Self {
        Motion {
            ang: zero3(),
            lin: zero3(),
        }
    }

    /// A constant motion (a joint's motion subspace) times a scalar (its rate).
    pub fn from_axis(s: &Motion<f64>, rate: S) -> Self {
        Motion {
            ang: [rate * s.ang[0], rate * s.ang[1], rate * s.ang[2]],
            lin: [rate * s.lin[0], rate * s.lin[1], rate * s.lin[2]],
        }
    }

    pub fn add(&self, o: &Self) -> Self {
        Motion {
            ang: add(&self.ang, &o.ang),
            lin: add(&self.lin, &o.lin),
        }
    }

    /// `self ×m m` (Featherstone's crm): `(ω × m_ω, ω × m_v + v × m_ω)`.
    pub fn cross_motion(&self, m: &Motion<S>) -> Motion<S> {
        Motion {
            ang: cross(&self.ang, &m.ang),
            lin: add(&cross(&self.ang, &m.lin), &cross(&self.lin, &m.ang)),
        }
    }

    /// `self ×* f` (Featherstone's crf): `(ω × n + v × f, ω × f)`.
    pub fn cross_force(&self, f: &Force<S>) -> Force<S> {
        Force {
            ang: add(&cross(&self.ang, &f.ang), &cross(&self.lin, &f.lin)),
            lin: cross(&self.ang, &f.lin),
        }
    }

    /// The power `m · f`.
    pub fn dot(&self, f: &Force<S>) -> S {
        dot(&self.ang, &f.ang) + dot(&self.lin, &f.lin)
    }
}

impl<S: Scalar> Force<S> {
    pub fn zero() -> Self {
        Force {
            ang: zero3(),
            lin: zero3(),
        }
    }

    pub fn add(&self, o: &Self) -> Self {
        Force {
            ang: add(&self.ang, &o.ang),
            lin: add(&self.lin, &o.lin),
        }
    }

    pub fn sub(&self, o: &Self) -> Self {
        Force {
            ang: sub(&self.ang, &o.ang),
            lin: sub(&self.lin, &o.lin),
        }
    }

    pub fn scale(&self, s: S) -> Self {
        Force {
            ang: scale(&self.ang, s),
            lin: scale(&self.lin, s),
        }
    }

    /// `sᵀ f` for a constant motion `s` (a joint's motion subspace).
    pub fn along(&self, s: &Motion<f64>) -> S {
        self.ang[0] * s.ang[0]
            + self.ang[1] * s.ang[1]
            + self.ang[2] * s.ang[2]
            + self.lin[0] * s.lin[0]
            + self.lin[1] * s.lin[1]
            + self.lin[2] * s.lin[2]
    }
}

/// A Plücker transform `B_X_A`: `e` takes A-coordinates to B-coordinates, `r` is B's
/// origin in A-coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform<S> {
    pub e: M3<S>,
    pub r: V3<S>,
}

impl<S: Scalar> Transform<S> {
    /// `X m`: a motion in A-coordinates expressed in B.
    pub fn motion(&self, m: &Motion<S>) -> Motion<S> {
        Motion {
            ang: mat_vec(&self.e, &m.ang),
            lin: mat_vec(&self.e, &sub(&m.lin, &cross(&self.r, &m.ang))),
        }
    }

    /// `Xᵀ f` = `A_X*_B f`: a force in B-coordinates expressed in A.
    pub fn force_back(&self, f: &Force<S>) -> Force<S> {
        let lin = mat_t_vec(&self.e, &f.lin);
        Force {
            ang: add(&mat_t_vec(&self.e, &f.ang), &cross(&self.r, &lin)),
            lin,
        }
    }
}

/// A rigid-body spatial inertia about a frame's origin, in its axes: mass `m`, first
/// moment `h = m c` (c the centre of mass) and rotational inertia `i` about the origin
/// (`I_c − m [c]×²`). `I v = (i ω + h × v, m v − h × ω)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidInertia<S> {
    pub m: S,
    pub h: V3<S>,
    pub i: M3<S>,
}

impl<S: Scalar> RigidInertia<S> {
    /// From mass, centre of mass and the inertia about the centre of mass.
    pub fn from_com(m: S, c: &V3<S>, i_c: &M3<S>) -> Self {
        let cx = skew(c);
        let cxcx = mat_mul(&cx, &cx);
        let mut i = *i_c;
        for r in 0..3 {
            for k in 0..3 {
                i[r][k] -= m * cxcx[r][k];
            }
        }
        RigidInertia {
            m,
            h: scale(c, m),
            i,
        }
    }

    pub fn lift(inertia: &RigidInertia<f64>) -> Self {
        RigidInertia {
            m: S::from(inertia.m),
            h: lift3(&inertia.h),
            i: lift33(&inertia.i),
        }
    }

    pub fn add(&self, o: &Self) -> Self {
        RigidInertia {
            m: self.m + o.m,
            h: add(&self.h, &o.h),
            i: mat_add(&self.i, &o.i),
        }
    }

    /// `I v`.
    pub fn apply(&self, v: &Motion<S>) -> Force<S> {
        Force {
            ang: add(&mat_vec(&self.i, &v.ang), &cross(&self.h, &v.lin)),
            lin: sub(&scale(&v.lin, self.m), &cross(&self.h, &v.ang)),
        }
    }

    /// `Xᵀ I X`: this inertia (in B) expressed in A, for `x = B_X_A`. With `R = Eᵀ`:
    /// `h_A = R h + m r`, `i_A = R i Rᵀ − [Rh]×[r]× − [r]×[Rh]× − m [r]×²`.
    pub fn back(&self, x: &Transform<S>) -> Self {
        let rt = transpose(&x.e);
        let rh = mat_vec(&rt, &self.h);
        let rot = mat_mul(&mat_mul(&rt, &self.i), &x.e);
        let (rx, rhx) = (skew(&x.r), skew(&rh));
        let rxrx = mat_mul(&rx, &rx);
        let mut i = mat_sub(&rot, &mat_add(&mat_mul(&rhx, &rx), &mat_mul(&rx, &rhx)));
        for r in 0..3 {
            for k in 0..3 {
                i[r][k] -= self.m * rxrx[r][k];
            }
        }
        RigidInertia {
            m: self.m,
            h: add(&rh, &scale(&x.r, self.m)),
            i,
        }
    }
}

/// A general symmetric 6×6 (articulated-body) inertia `[[a, b], [bᵀ, c]]`:
/// `I v = (a ω + b v, bᵀ ω + c v)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArticulatedInertia<S> {
    pub a: M3<S>,
    pub b: M3<S>,
    pub c: M3<S>,
}

impl<S: Scalar> ArticulatedInertia<S> {
    pub fn from_rigid(r: &RigidInertia<S>) -> Self {
        let z = S::zero();
        let m = r.m;
        ArticulatedInertia {
            a: r.i,
            b: skew(&r.h),
            c: [[m, z, z], [z, m, z], [z, z, m]],
        }
    }

    pub fn add(&self, o: &Self) -> Self {
        ArticulatedInertia {
            a: mat_add(&self.a, &o.a),
            b: mat_add(&self.b, &o.b),
            c: mat_add(&self.c, &o.c),
        }
    }

    /// `I v`.
    pub fn apply(&self, v: &Motion<S>) -> Force<S> {
        Force {
            ang: add(&mat_vec(&self.a, &v.ang), &mat_vec(&self.b, &v.lin)),
            lin: add(&mat_t_vec(&self.b, &v.ang), &mat_vec(&self.c, &v.lin)),
        }
    }

    /// `I − u uᵀ / d` for `u = (u_ang, u_lin)` given as a force.
    pub fn minus_outer(&self, u: &Force<S>, d_inv: S) -> Self {
        ArticulatedInertia {
            a: mat_sub(&self.a, &outer(&u.ang, &u.ang, d_inv)),
            b: mat_sub(&self.b, &outer(&u.ang, &u.lin, d_inv)),
            c: mat_sub(&self.c, &outer(&u.lin, &u.lin, d_inv)),
        }
    }

    /// `Xᵀ I X` for `x = B_X_A`. `X = diag(E, E) T` with `T = [[1, 0], [−[r]×, 1]]`
    /// (`Tᵀ = [[1, [r]×], [0, 1]]`, `[r]×` being skew); the rotation gives `a' = Eᵀ a E`
    /// (and b', c' alike), then `Tᵀ I' T` gives
    /// `a'' = a' − b'[r]× + [r]× b'ᵀ − [r]× c' [r]×`, `b'' = b' + [r]× c'`, `c'' = c'`.
    pub fn back(&self, x: &Transform<S>) -> Self {
        let et = transpose(&x.e);
        let rot = |m: &M3<S>| mat_mul(&mat_mul(&et, m), &x.e);
        let (a, b, c) = (rot(&self.a), rot(&self.b), rot(&self.c));
        let rx = skew(&x.r);
        let rxc = mat_mul(&rx, &c);
        let a2 = mat_sub(
            &mat_add(
                &mat_sub(&a, &mat_mul(&b, &rx)),
                &mat_mul(&rx, &transpose(&b)),
            ),
            &mat_mul(&rxc, &rx),
        );
        ArticulatedInertia {
            a: a2,
            b: mat_add(&b, &rxc),
            c,
        }
    }
}
