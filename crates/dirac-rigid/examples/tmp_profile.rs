use dirac_core::Discretisation;
use dirac_graph::{Assembler, Interconnection, Representation};
use dirac_rigid::{RigidBody, so3};
use dirac_sim::{Integrator, IntegratorOptions};
fn main() {
    let body = RigidBody::principal(1.0, [1.0, 1.5, 2.0]).unwrap();
    let mut g = Interconnection::new();
    g.add_subsystem(body.subsystem("b")).unwrap();
    let r0 = so3::from_axis_angle([1.0, 1.0, 1.0], 0.3);
    let q0 = RigidBody::coordinates([0.0; 3], &r0);
    let v0 = RigidBody::rates(&r0, [0.0; 3], [0.3, 3.0, -0.2]);
    let sys = Assembler::assemble(&g, Representation::Monolithic).unwrap();
    let mut sim = Integrator::new(
        sys.model.clone(),
        sys.constraints.clone(),
        IntegratorOptions::new(Discretisation::trapezoid(), 0.01),
    )
    .unwrap();
    sim.initialise(&q0, &v0, 0.0).unwrap();
    let t = std::time::Instant::now();
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(200000);
    for _ in 0..n {
        sim.step().unwrap();
    }
    println!("{:?} per step, {:?}", t.elapsed() / n as u32, sim.stats());
}
