use dirac_core::Discretisation;
use dirac_graph::{Assembler, Representation};
use dirac_rigid::mechanisms::PendulumChain;
use dirac_sim::{Integrator, IntegratorOptions};
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(10);
    let m = PendulumChain::dart(n).build().unwrap();
    let sys = Assembler::assemble(&m.graph, Representation::Monolithic).unwrap();
    let q = sys.global_vector(&m.q0, &m.names()).unwrap();
    let v = sys.global_vector(&m.v0, &m.names()).unwrap();
    let mut opts = IntegratorOptions::new(Discretisation::trapezoid(), 1e-3);
    if std::env::args().nth(2).is_some() {
        opts.newton.reuse_jacobian = false;
    }
    let mut sim = Integrator::new(sys.model.clone(), sys.constraints.clone(), opts).unwrap();
    sim.initialise(&q, &v, 0.0).unwrap();
    for k in 0..40 {
        let r = sim.step().unwrap();
        if k % 4 == 0 || k < 5 {
            println!("{k} {:?}", r.newton);
        }
    }
}
