//! Rigid bodies in space for [`Lagrangian`](super::lagrangian::Lagrangian)s: a multibody
//! system's kinetic energy written as the bodies' poses only.
//!
//! A system writes where each body's centre of mass is and how it is turned, as
//! functions of q ([`Pose`]); evaluated at the dual point `q + ε q̇` ([`along`]) the ε parts
//! are the velocities: `v = d/dt com`, `Ṙ`, so `ω` (body axes) `= vee(Rᵀ Ṙ)`. No velocity
//! or angular velocity is derived by hand, and the whole chain stays generic over the
//! scalar, so the framework's own dual numbers (mass matrix, Jacobians) and the symbolic
//! tracer pass through it.
//!
//! Conventions: a rotation matrix maps body components to world components; rotations are
//! right-handed about their axis.

use super::Scalar;
use num_dual::Dual;

pub type Vec3<S> = [S; 3];
pub type Mat3<S> = [[S; 3]; 3];

/// `q + ε q̇`: the configuration moving with the velocities, so that a function of it
/// carries its time derivative in the ε parts.
pub fn along<S: Scalar, const N: usize>(q: &[S], qd: &[S]) -> [Dual<S>; N] {
    std::array::from_fn(|i| Dual::new(q[i], qd[i]))
}

/// Parameters (or anything constant along the motion) lifted to dual numbers.
pub fn constant<S: Scalar, const N: usize>(p: &[S]) -> [Dual<S>; N] {
    std::array::from_fn(|i| Dual::from_re(p[i]))
}

pub fn vec3<S: Scalar>(x: f64, y: f64, z: f64) -> Vec3<S> {
    [S::from(x), S::from(y), S::from(z)]
}

pub fn add<S: Scalar>(a: Vec3<S>, b: Vec3<S>) -> Vec3<S> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn sub<S: Scalar>(a: Vec3<S>, b: Vec3<S>) -> Vec3<S> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn scale<S: Scalar>(s: S, a: Vec3<S>) -> Vec3<S> {
    [s * a[0], s * a[1], s * a[2]]
}

pub fn dot<S: Scalar>(a: Vec3<S>, b: Vec3<S>) -> S {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross<S: Scalar>(a: Vec3<S>, b: Vec3<S>) -> Vec3<S> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a · v`.
pub fn apply<S: Scalar>(a: &Mat3<S>, v: Vec3<S>) -> Vec3<S> {
    std::array::from_fn(|i| dot(a[i], v))
}

/// `a · b`.
pub fn mul<S: Scalar>(a: &Mat3<S>, b: &Mat3<S>) -> Mat3<S> {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j])
    })
}

pub fn transpose<S: Scalar>(a: &Mat3<S>) -> Mat3<S> {
    std::array::from_fn(|i| std::array::from_fn(|j| a[j][i]))
}

/// Column `j` of `a`: where body axis j points in the world.
pub fn column<S: Scalar>(a: &Mat3<S>, j: usize) -> Vec3<S> {
    [a[0][j], a[1][j], a[2][j]]
}

/// Rotation by `angle` about x.
pub fn rot_x<S: Scalar>(angle: S) -> Mat3<S> {
    let (s, c, o, z) = (angle.sin(), angle.cos(), S::from(1.0), S::from(0.0));
    [[o, z, z], [z, c, -s], [z, s, c]]
}

/// Rotation by `angle` about y.
pub fn rot_y<S: Scalar>(angle: S) -> Mat3<S> {
    let (s, c, o, z) = (angle.sin(), angle.cos(), S::from(1.0), S::from(0.0));
    [[c, z, s], [z, o, z], [-s, z, c]]
}

/// Rotation by `angle` about z.
pub fn rot_z<S: Scalar>(angle: S) -> Mat3<S> {
    let (s, c, o, z) = (angle.sin(), angle.cos(), S::from(1.0), S::from(0.0));
    [[c, -s, z], [s, c, z], [z, z, o]]
}

/// Rotation by `angle` about the unit axis `u` (Rodrigues: `c I + s [u]× + (1 − c) u uᵀ`).
pub fn rot_axis<S: Scalar>(u: Vec3<S>, angle: S) -> Mat3<S> {
    let (s, c) = (angle.sin(), angle.cos());
    let k = S::from(1.0) - c;
    let ux = [
        [S::from(0.0), -u[2], u[1]],
        [u[2], S::from(0.0), -u[0]],
        [-u[1], u[0], S::from(0.0)],
    ];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let diagonal = if i == j { c } else { S::from(0.0) };
            diagonal + s * ux[i][j] + k * u[i] * u[j]
        })
    })
}

/// The vector of a skew-symmetric matrix `[w]×`.
fn vee<S: Scalar>(w: &Mat3<S>) -> Vec3<S> {
    [w[2][1], w[0][2], w[1][0]]
}

/// Where a body is: its centre of mass and its orientation (body to world).
#[derive(Clone, Copy, Debug)]
pub struct Pose<S> {
    pub com: Vec3<S>,
    pub rot: Mat3<S>,
}

/// Mass and inertia tensor about the centre of mass, in body axes.
#[derive(Clone, Copy, Debug)]
pub struct Inertia<S> {
    pub mass: S,
    pub tensor: Mat3<S>,
}

impl<S: Scalar> Inertia<S> {
    /// A body symmetric about its xz-plane (a bicycle frame): `Ixy = Iyz = 0`.
    pub fn xz_symmetric(mass: S, ixx: S, iyy: S, izz: S, ixz: S) -> Self {
        let z = S::from(0.0);
        Inertia {
            mass,
            tensor: [[ixx, z, ixz], [z, iyy, z], [ixz, z, izz]],
        }
    }
}

/// `(v, ω)` of a pose evaluated at `q + ε q̇`: the velocity of the centre of mass and
/// the angular velocity, both in world components (`[ω]× = Ṙ Rᵀ`).
pub fn velocities<S: Scalar>(pose: &Pose<Dual<S>>) -> (Vec3<S>, Vec3<S>) {
    let v = pose.com.map(|c| c.eps);
    let (r, rdot) = split(&pose.rot);
    (v, vee(&mul(&rdot, &transpose(&r))))
}

/// The velocity of the material point of a body that is at `point` now (world
/// components, real parts taken): `v + ω × (point − com)`.
pub fn point_velocity<S: Scalar>(pose: &Pose<Dual<S>>, point: Vec3<S>) -> Vec3<S> {
    let (v, omega) = velocities(pose);
    let com = pose.com.map(|c| c.re);
    add(v, cross(omega, sub(point, com)))
}

/// `½ m |v|² + ½ ωᵀ I ω` (ω in body axes, `[ω]× = Rᵀ Ṙ`) of a body whose pose is
/// evaluated at `q + ε q̇`.
pub fn kinetic_energy<S: Scalar>(pose: &Pose<Dual<S>>, inertia: &Inertia<S>) -> S {
    let v = pose.com.map(|c| c.eps);
    let (r, rdot) = split(&pose.rot);
    let omega = vee(&mul(&transpose(&r), &rdot));
    (inertia.mass * dot(v, v) + dot(omega, apply(&inertia.tensor, omega))) * 0.5
}

/// A dual matrix as its real and ε parts.
fn split<S: Scalar>(a: &Mat3<Dual<S>>) -> (Mat3<S>, Mat3<S>) {
    (
        a.map(|row| row.map(|x| x.re)),
        a.map(|row| row.map(|x| x.eps)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spinning_body_about_a_tilted_axis() {
        // A body turning at rate w about the unit axis u through its centre of mass:
        // ω = w u in the world, T = ½ w² uᵀ R I Rᵀ u.
        let u: [f64; 3] = [0.6, 0.0, 0.8];
        let (angle, rate): (f64, f64) = (0.7, 1.3);
        let a = Dual::new(angle, rate);
        let rot = rot_axis(u.map(Dual::from_re), a);
        let pose = Pose {
            com: [Dual::from_re(1.0), Dual::from_re(2.0), Dual::from_re(3.0)],
            rot,
        };
        let (v, omega) = velocities(&pose);
        assert_eq!(v, [0.0; 3]);
        for k in 0..3 {
            assert!((omega[k] - rate * u[k]).abs() < 1e-15);
        }
        let inertia = Inertia::xz_symmetric(2.0, 1.0, 2.0, 3.0, 0.5);
        let r = rot_axis(u, angle);
        let world = mul(&mul(&r, &inertia.tensor), &transpose(&r));
        let expected = 0.5 * rate * rate * dot(u, apply(&world, u));
        assert!((kinetic_energy(&pose, &inertia) - expected).abs() < 1e-14);
        // The rim point at the origin moves with ω × (0 − com).
        let pv = point_velocity(&pose, [0.0; 3]);
        let expected = cross(omega, [-1.0, -2.0, -3.0]);
        for k in 0..3 {
            assert!((pv[k] - expected[k]).abs() < 1e-14);
        }
    }

    #[test]
    fn elementary_rotations_are_right_handed() {
        let q = std::f64::consts::FRAC_PI_2;
        let close = |a: Vec3<f64>, b: Vec3<f64>| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-15);
        assert!(close(apply(&rot_x(q), [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
        assert!(close(apply(&rot_y(q), [0.0, 0.0, 1.0]), [1.0, 0.0, 0.0]));
        assert!(close(apply(&rot_z(q), [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        assert!(close(
            apply(&rot_axis([0.0, 0.0, 1.0], q), [1.0, 0.0, 0.0]),
            [0.0, 1.0, 0.0]
        ));
    }
}
