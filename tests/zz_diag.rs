use glam::{Vec2, Vec3};
use photon_bench::geometry::spawn_ray;
use photon_bench::sampling::Rng;
use photon_bench::scene::load::load_scene_bytes;
use photon_bench::scene::luminance;
use photon_bench::strategy::Strategy;
use photon_bench::strategy::path::{PathParams, radiance};
use photon_bench::strategy::photon_guided::{GridSampler, PhotonGuided, PhotonGuidedParams};

#[test]
fn diag() {
    let text = std::fs::read_to_string("scenes/cornell-empty.toml").unwrap();
    let (scene, _) = load_scene_bytes(std::path::Path::new("scenes/cornell-empty.toml"), text.as_bytes()).unwrap();
    let params = PhotonGuidedParams::default();
    let mut s = PhotonGuided::new(params.clone()).unwrap();
    s.prepare(&scene, 1).unwrap();
    let sampler = GridSampler {
        map: s.map().unwrap(),
        params: &params,
    };
    let pp = PathParams::default();
    for px in [Vec2::new(40.5, 40.5), Vec2::new(10.5, 30.5), Vec2::new(40.5, 55.5)] {
        let ray = scene.camera.generate_ray(px);
        let hit = scene.intersect(&ray).unwrap();
        let grid = sampler.grid_at(&hit, false);
        let (m, n) = (4usize, 16usize);
        let mut rng = Rng::for_task(7, [0, 0, 0]);
        let mut true_c = vec![0f64; m * n];
        let mut pg = vec![0f64; m * n];
        let k = 4000;
        for i in 0..m {
            for j in 0..n {
                let mut acc = 0f64;
                for _ in 0..k {
                    let u = rng.uniform2();
                    let uu = (i as f32 + u.x) / m as f32;
                    let vv = (j as f32 + u.y) / n as f32;
                    let st = uu.sqrt();
                    let ct = (1.0 - uu).sqrt();
                    let phi = std::f32::consts::TAU * vv;
                    let wl = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                    let w = hit.frame.to_world(wl);
                    let r = spawn_ray(hit.p, hit.ng, w);
                    acc += luminance(radiance(&scene, &pp, r, &mut rng)) as f64;
                }
                // ∫_cell L cos dω = π/cells · mean L
                true_c[i * n + j] = acc / k as f64;
                let wl = {
                    let uu = (i as f32 + 0.5) / m as f32;
                    let vv = (j as f32 + 0.5) / n as f32;
                    let phi = std::f32::consts::TAU * vv;
                    Vec3::new(uu.sqrt() * phi.cos(), uu.sqrt() * phi.sin(), (1.0 - uu).sqrt())
                };
                pg[i * n + j] = (grid.pdf(wl) / (wl.z / std::f32::consts::PI)) as f64 / (m * n) as f64;
            }
        }
        let tot: f64 = true_c.iter().sum();
        // variance of the estimator of ∫ L cos dω/π (mean over cells) ∝ Σ (I_c/cells)^2 / p_c - mean^2
        let cells = (m * n) as f64;
        let mean = tot / cells;
        let var_g: f64 = true_c
            .iter()
            .zip(&pg)
            .map(|(i, p)| (i / cells).powi(2) / p)
            .sum::<f64>()
            - mean * mean;
        let var_c: f64 = true_c.iter().map(|i| (i / cells).powi(2) * cells).sum::<f64>() - mean * mean;
        let ideal: f64 = true_c
            .iter()
            .map(|i| i / tot)
            .collect::<Vec<_>>()
            .iter()
            .zip(&true_c)
            .map(|(p, i)| (i / cells).powi(2) / p)
            .sum::<f64>()
            - mean * mean;
        println!(
            "px {px} p {} n {}: mean L {mean:.3}  var between-cell cos {var_c:.4} guided {var_g:.4} ideal-grid {ideal:.4}",
            hit.p, hit.frame.n
        );
        for i in 0..m {
            let t: Vec<String> = (0..n)
                .map(|j| format!("{:5.1}", 100.0 * true_c[i * n + j] / tot))
                .collect();
            let g: Vec<String> = (0..n).map(|j| format!("{:5.1}", 100.0 * pg[i * n + j])).collect();
            println!("true {}\ngrid {}", t.join(""), g.join(""));
        }
    }
}

#[test]
fn diag_var() {
    use photon_bench::strategy::path::{BsdfSampling, Direct, Roulette, Walk, trace};
    let text = std::fs::read_to_string("scenes/desk-lamp.toml").unwrap();
    let (scene, _) = load_scene_bytes(std::path::Path::new("scenes/desk-lamp.toml"), text.as_bytes()).unwrap();
    for (md, roulette) in [(1u32, Roulette::Albedo), (2, Roulette::Albedo), (16, Roulette::Albedo)] {
        let walk = Walk {
            max_depth: md,
            rr_depth: 3,
            roulette,
            direct: Direct::Mis,
        };
        println!("max_depth {md} {roulette:?}");
        for (np, nn) in [(33000u64, 50usize)] {
            let params = PhotonGuidedParams {
                photons: np,
                nearest: nn,
                ..Default::default()
            };
            let mut s = PhotonGuided::new(params.clone()).unwrap();
            s.prepare(&scene, 1).unwrap();
            let sampler = GridSampler {
                map: s.map().unwrap(),
                params: &params,
            };
            for px in [Vec2::new(65.5, 48.5), Vec2::new(64.5, 51.5), Vec2::new(100.5, 40.5)] {
                let ray = scene.camera.generate_ray(px);
                let stats = |f: &dyn Fn(&mut Rng) -> f32| {
                    let mut rng = Rng::for_task(9, [px.x as u64, px.y as u64, 0]);
                    let k = 100_000;
                    let (mut s1, mut s2, mut mx) = (0f64, 0f64, 0f32);
                    for _ in 0..k {
                        let v = f(&mut rng);
                        s1 += v as f64;
                        s2 += (v as f64).powi(2);
                        mx = mx.max(v);
                    }
                    let m = s1 / k as f64;
                    (m, s2 / k as f64 - m * m, mx)
                };
                let a = stats(&|rng| luminance(trace(&scene, &walk, &BsdfSampling::Importance, ray, rng, &mut ())));
                let b = stats(&|rng| luminance(trace(&scene, &walk, &sampler, ray, rng, &mut ())));
                println!(
                    "Np {np} N {nn} px {px}: cos mean {:.3} var {:.3} max {:.1} | guided mean {:.3} var {:.3} max {:.1} | ratio {:.2}",
                    a.0,
                    a.1,
                    a.2,
                    b.0,
                    b.1,
                    b.2,
                    a.1 / b.1
                );
            }
        }
    }
}
