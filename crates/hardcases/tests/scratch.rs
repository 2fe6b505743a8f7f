use sahara_geom::*;
use sahara_hardcases::corpus::*;
#[test]
fn scratch() {
    let c = corpus(Target::Scene);
    for k in [1820usize, 2564, 302] {
        let d = &c
            .iter()
            .find(|i| i.name == format!("scene bytes {k}"))
            .unwrap()
            .data;
        let n = (d[0] % 16) as usize;
        let f: Vec<f32> = d[1..]
            .chunks(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let tris: Vec<Triangle> = (0..n)
            .map(|t| {
                Triangle::new(
                    Vec3A::from_slice(&f[9 * t..]),
                    Vec3A::from_slice(&f[9 * t + 3..]),
                    Vec3A::from_slice(&f[9 * t + 6..]),
                )
            })
            .collect();
        let r: Vec<Ray> = f[9 * n..]
            .chunks_exact(8)
            .map(|r| {
                Ray::new(
                    Vec3A::new(r[0], r[1], r[2]),
                    Vec3A::new(r[3], r[4], r[5]),
                    r[6],
                    r[7],
                )
            })
            .collect();
        let ray = r[if k == 302 {
            2
        } else if k == 2564 {
            0
        } else {
            0
        }];
        let h = sahara_traverse::brute::closest_hit(&tris, &ray);
        println!(
            "{k}: ray {:?}\n hit {:?}\n tri {:?} area {} point {:?}",
            ray,
            h,
            tris[h.prim as usize].v,
            tris[h.prim as usize].area(),
            ray.at(h.t)
        );
    }
}
