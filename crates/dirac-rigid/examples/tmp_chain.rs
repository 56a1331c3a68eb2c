use dirac_core::Discretisation;
use dirac_graph::{Assembler, Representation};
use dirac_rigid::mechanisms::PendulumChain;
use dirac_sim::{Integrator, IntegratorOptions};
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(10);
    let steps: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1000);
    let m = PendulumChain::dart(n).build().unwrap();
    let sys = Assembler::assemble(&m.graph, Representation::Monolithic).unwrap();
    let q = sys.global_vector(&m.q0, &m.names()).unwrap();
    let v = sys.global_vector(&m.v0, &m.names()).unwrap();
    let mut opts = IntegratorOptions::new(Discretisation::trapezoid(), 1e-3);
    if std::env::args().nth(3).is_some() {
        opts.newton.reuse_jacobian = false;
    }
    let mut sim = Integrator::new(sys.model.clone(), sys.constraints.clone(), opts).unwrap();
    sim.initialise(&q, &v, 0.0).unwrap();
    println!("unknowns {} warnings {:?}", sim.unknowns(), sim.warnings());
    let t = std::time::Instant::now();
    for _ in 0..steps {
        sim.step().unwrap();
    }
    let s = sim.stats();
    println!(
        "{:?} per step ({:?} per body), iter/step {:.2} fact/step {:.3}",
        t.elapsed() / steps as u32,
        t.elapsed() / (steps * n) as u32,
        s.iterations as f64 / steps as f64,
        s.factorisations as f64 / steps as f64
    );
}
