use fluid_node::ranks::comm::Comm;
use std::time::{Duration, Instant};
fn main() {
    let c = fluid_node::ranks::mpi::MpiRanks::init().unwrap();
    let me = c.rank();
    let other = 1 - me;
    for &n in &[1usize << 10, 64 << 10, 640 << 10, 2 << 20] {
        let mut t = 0.0;
        for i in 0..300 {
            c.max(&mut [0.0]);
            if me == 0 {
                let s = Instant::now();
                while s.elapsed() < Duration::from_micros(2000) {}
            }
            let s = Instant::now();
            let got = c.exchange(vec![(other, vec![1u8; n])]);
            if i >= 20 {
                t += s.elapsed().as_secs_f64();
            }
            assert_eq!(got[0].len(), n);
        }
        let all = c.gather(t.to_le_bytes().to_vec());
        if me == 0 {
            let t1 = f64::from_le_bytes(all[1][..8].try_into().unwrap());
            println!(
                "{n} bytes: late rank 0 {:.1} us, early rank 1 {:.1} us (incl. 2000 wait)",
                1e6 * t / 280.0,
                1e6 * t1 / 280.0
            );
        }
    }
}
