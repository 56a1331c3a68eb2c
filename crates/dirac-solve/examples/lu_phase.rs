use dirac_solve::{LinearSolver, SparseLu};
use std::time::Instant;
fn main() {
    for path in std::env::args().skip(1) {
        let text = std::fs::read_to_string(&path).unwrap();
        let mut lines = text.lines();
        let n: usize = lines.next().unwrap().parse().unwrap();
        let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
        for l in lines {
            let mut it = l.split_whitespace();
            rows.push(it.next().unwrap().parse::<usize>().unwrap());
            cols.push(it.next().unwrap().parse::<usize>().unwrap());
            vals.push(it.next().unwrap().parse::<f64>().unwrap());
        }
        // row-equilibrate as Newton does
        let mut rmax = vec![0.0f64; n];
        for (&r, &v) in rows.iter().zip(&vals) {
            rmax[r] = rmax[r].max(v.abs());
        }
        for (&r, v) in rows.iter().zip(vals.iter_mut()) {
            *v /= rmax[r];
        }
        let (mut first, mut an, mut refac, mut solve) = (f64::MAX, f64::MAX, f64::MAX, f64::MAX);
        let mut nnz = 0;
        for _ in 0..15 {
            let mut lu = SparseLu::new();
            let t = Instant::now();
            lu.analyse(n, &rows, &cols).unwrap();
            an = an.min(t.elapsed().as_secs_f64());
            let t = Instant::now();
            lu.factor(&vals).unwrap();
            first = first.min(t.elapsed().as_secs_f64());
            nnz = lu.nnz();
            let scaled: Vec<f64> = vals.iter().map(|v| v * 1.001).collect();
            for _ in 0..5 {
                let t = Instant::now();
                lu.factor(&scaled).unwrap();
                refac = refac.min(t.elapsed().as_secs_f64());
                let mut b = vec![1.0; n];
                let t = Instant::now();
                lu.solve_in_place(&mut b).unwrap();
                solve = solve.min(t.elapsed().as_secs_f64());
            }
        }
        println!(
            "{path}: n {n} nnz {nnz} analyse {:.3} ms first factor {:.3} ms refactor {:.3} ms solve {:.1} µs",
            an * 1e3,
            first * 1e3,
            refac * 1e3,
            solve * 1e6
        );
    }
}
