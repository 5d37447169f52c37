//! The whole hierarchy against testing every primitive: built still or moving, refitted,
//! traversed.

use glam::DVec3;

use crate::aabb::Aabb;
use crate::rng::Pcg32;

use super::hierarchy::Bvh;
use super::stack::TraversalStack;
use super::traverse::BvhView;

fn brute(centers: &[(DVec3, f64)], ray: &crate::ray::Ray) -> Option<(f64, u32)> {
    let mut best: Option<(f64, u32)> = None;
    for (i, (c, r)) in centers.iter().enumerate() {
        if let Some(t) = crate::sphere::intersect(*c, *r, ray, best.map_or(f64::INFINITY, |b| b.0))
        {
            best = Some((t, i as u32));
        }
    }
    best
}

fn random_rays(r: &mut Pcg32, n: usize) -> Vec<crate::ray::Ray> {
    (0..n)
        .map(|_| {
            let o = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 30.0 - 15.0;
            let mut d = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5;
            // Some axis-parallel rays, whose reciprocal direction has infinities.
            if r.next_f64() < 0.1 {
                d.x = 0.0;
            }
            if r.next_f64() < 0.1 {
                d.y = 0.0;
            }
            crate::ray::Ray {
                origin: o,
                dir: d.normalize(),
                time: r.next_f64(),
            }
        })
        .collect()
}

#[test]
fn agrees_with_brute_force() {
    let mut r = Pcg32::new(11, 1);
    let mut stack = TraversalStack::default();
    // 200,000: spans that bin a sample and are partitioned in parallel (`build.rs`).
    for &n in &[0usize, 1, 2, 5, 17, 300, 2000, 9000, 200_000] {
        let centers: Vec<(DVec3, f64)> = (0..n)
            .map(|_| {
                let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
                (c, 0.05 + r.next_f64() * 0.5)
            })
            .collect();
        let boxes: Vec<Aabb> = centers
            .iter()
            .map(|(c, rad)| Aabb::point(*c).grow(*rad))
            .collect();
        let bvh = Bvh::build(&boxes);
        assert_eq!(bvh.len(), n);
        for ray in random_rays(&mut r, if n > 10_000 { 100 } else { 500 }) {
            let got = bvh.closest_hit(
                ray.origin,
                ray.dir,
                0.0,
                f64::INFINITY,
                &mut stack,
                |p, tmax| {
                    let (c, rad) = centers[bvh.order()[p as usize] as usize];
                    crate::sphere::intersect(c, rad, &ray, tmax)
                },
            );
            let got = got.map(|(t, p)| (t, bvh.order()[p as usize]));
            assert_eq!(got, brute(&centers, &ray));
        }
    }
}

/// Rays with NaN or infinite parts, and boxes with NaN sides, find nothing and never
/// overflow the traversal stack, in still and moving hierarchies of any size.
#[test]
fn non_finite_rays_and_boxes_find_nothing() {
    let mut r = Pcg32::new(13, 5);
    let mut stack = TraversalStack::default();
    let (nan, inf) = (f64::NAN, f64::INFINITY);
    let rays = [
        (DVec3::splat(nan), DVec3::X),
        (DVec3::ZERO, DVec3::splat(nan)),
        (DVec3::new(0.0, nan, 0.0), DVec3::new(0.0, 0.0, 1.0)),
        (DVec3::splat(inf), DVec3::X),
        (DVec3::ZERO, DVec3::splat(inf)),
        (DVec3::ZERO, DVec3::new(-inf, 1.0, 0.0)),
        (DVec3::splat(-inf), DVec3::splat(inf)),
    ];
    for &n in &[1usize, 5, 300, 9000] {
        let boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
                Aabb::point(c).grow(0.5)
            })
            .collect();
        let still = Bvh::build(&boxes);
        let moving = Bvh::build_moving(&boxes, &boxes);
        for bvh in [&still, &moving] {
            for s in [0.0, 0.5, nan] {
                for &(origin, dir) in &rays {
                    let got = bvh.closest_hit(origin, dir, s, inf, &mut stack, |_, _| {
                        panic!("a non-finite ray reached a primitive")
                    });
                    assert_eq!(got, None);
                }
            }
        }
        // Boxes with NaN sides (refitted onto the topology) are entered by every ray, since
        // the slab test ignores NaN: the traversal still visits each leaf once, no more.
        let bad = vec![Aabb::point(DVec3::splat(nan)); n];
        let boxes = moving.topology().refit_moving(&bad, &bad);
        // Compact nodes cannot hold them: a compact refit keeps `f32` sides instead.
        let kept = moving.topology().refit_compact_with(&|_| (bad[0], bad[0]));
        assert!(matches!(kept.nodes, super::boxes::Nodes::Moving(_)));
        let view = BvhView::new(moving.topology(), &boxes);
        for ray in random_rays(&mut r, 20) {
            let mut visits = 0;
            let got = view.closest_hit(ray.origin, ray.dir, 0.5, inf, &mut stack, |_, _| {
                visits += 1;
                None
            });
            assert_eq!(got, None);
            assert!(visits <= n, "{visits} visits of {n} primitives");
        }
        // The same for a packet: each ray visits each leaf once at most.
        let rays: Vec<super::PacketRay> = random_rays(&mut r, super::PACKET)
            .iter()
            .map(|ray| super::PacketRay {
                origin: ray.origin,
                dir: ray.dir,
                s: 0.5,
            })
            .collect();
        let mut visits = [0usize; super::PACKET];
        let got = view.closest_hits(&rays, [inf; super::PACKET], &mut stack, |lane, _, _| {
            visits[lane] += 1;
            None
        });
        assert_eq!(got, [None; super::PACKET]);
        assert!(visits.iter().all(|&v| v <= n), "{visits:?} of {n}");
        // And for rays walking in turns.
        let mut visits = [0usize; super::PACKET];
        let got =
            view.closest_hits_in_turns(&rays, [inf; super::PACKET], &mut stack, |lane, _, _| {
                visits[lane] += 1;
                None
            });
        assert_eq!(got, [None; super::PACKET]);
        assert!(visits.iter().all(|&v| v <= n), "{visits:?} of {n}");
    }
}

/// Spheres moving on straight lines during the shutter: the hierarchy with interpolated
/// boxes finds exactly what testing every sphere at the ray's time finds.
#[test]
fn moving_agrees_with_brute_force() {
    let mut r = Pcg32::new(12, 3);
    let mut stack = TraversalStack::default();
    for &n in &[1usize, 3, 40, 700, 6000] {
        // A third still, the others slow or fast.
        let (spheres, open, close) = moving_spheres(&mut r, n);
        let bvh = Bvh::build_moving(&open, &close);
        let compact = compact_boxes(&bvh, &open, &close);
        for ray in random_rays(&mut r, 400) {
            assert!(moving_hit_is_brute(bvh.view(), &spheres, &ray, &mut stack));
            let view = BvhView::new(bvh.topology(), &compact);
            assert!(moving_hit_is_brute(view, &spheres, &ray, &mut stack));
        }
    }
}

/// The boxes of `bvh`'s topology over primitives with boxes `open` and `close`, compact.
fn compact_boxes(bvh: &Bvh, open: &[Aabb], close: &[Aabb]) -> super::Boxes {
    let topology = bvh.topology();
    let boxes = topology.refit_compact_with(&|pos| {
        let i = topology.order()[pos as usize] as usize;
        (open[i], close[i])
    });
    assert!(matches!(boxes.nodes, super::boxes::Nodes::Compact(_)));
    boxes
}

/// Whether `bvh` over the moving `spheres` finds what testing every sphere at the ray's
/// time finds (the ray's time is its shutter time `s`).
fn moving_hit_is_brute(
    bvh: BvhView,
    spheres: &[(DVec3, DVec3, f64)],
    ray: &crate::ray::Ray,
    stack: &mut TraversalStack,
) -> bool {
    let s = ray.time;
    let order = bvh.topology.order();
    let at = |i: usize| (spheres[i].0 + spheres[i].1 * s, spheres[i].2);
    let got = bvh.closest_hit(ray.origin, ray.dir, s, f64::INFINITY, stack, |p, tmax| {
        let (c, rad) = at(order[p as usize] as usize);
        crate::sphere::intersect(c, rad, ray, tmax)
    });
    let got = got.map(|(t, p)| (t, order[p as usize]));
    let now: Vec<(DVec3, f64)> = (0..spheres.len()).map(at).collect();
    got == brute(&now, ray)
}

/// Spheres `(centre at s = 0, velocity, radius)`, and their boxes at s = 0 and at s = 1.
type MovingSpheres = (Vec<(DVec3, DVec3, f64)>, Vec<Aabb>, Vec<Aabb>);

fn moving_spheres(r: &mut Pcg32, n: usize) -> MovingSpheres {
    let spheres: Vec<(DVec3, DVec3, f64)> = (0..n)
        .map(|i| {
            let c = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 20.0 - 10.0;
            let speed = [0.0, 0.5, 8.0][i % 3];
            let v = (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * speed;
            (c, v, 0.05 + r.next_f64() * 0.5)
        })
        .collect();
    let open = spheres
        .iter()
        .map(|(c, _, rad)| Aabb::point(*c).grow(*rad).pad_for_rounding())
        .collect();
    let close = spheres
        .iter()
        .map(|(c, v, rad)| Aabb::point(*c + *v).grow(*rad).pad_for_rounding())
        .collect();
    (spheres, open, close)
}

#[test]
fn refitted_hierarchies_agree_with_brute_force() {
    let mut r = Pcg32::new(21, 5);
    let mut stack = TraversalStack::default();
    for &n in &[1usize, 3, 40, 700, 6000] {
        // Built on one set of spheres, refitted to another: the tree is the first's.
        let (_, open0, close0) = moving_spheres(&mut r, n);
        let bvh = Bvh::build_moving(&open0, &close0);
        let topology = bvh.topology();
        // Refitting to the boxes it was built on gives the boxes of the build.
        assert_eq!(topology.refit_moving(&open0, &close0), *bvh.boxes());
        let (spheres, open, close) = moving_spheres(&mut r, n);
        let boxes = topology.refit_moving(&open, &close);
        // Unrelated positions: a much worse tree, but exact.
        if n > 100 {
            assert!(boxes.area() > 2.0 * bvh.area(), "{}", boxes.area());
        }
        // The topology with the new boxes finds every hit; with the boxes of the build
        // (a refit skipped) it misses some.
        let mut stale = 0;
        for ray in random_rays(&mut r, 300) {
            let view = BvhView::new(topology, &boxes);
            assert!(moving_hit_is_brute(view, &spheres, &ray, &mut stack));
            if !moving_hit_is_brute(bvh.view(), &spheres, &ray, &mut stack) {
                stale += 1;
            }
        }
        if n > 100 {
            assert!(stale > 0, "n {n}");
        }
    }
}

/// Spheres far from the origin (around 1e6) and tiny ones near it (around 1e-6), with rays
/// grazing them along the faces of their boxes, where rounding the boxes to `f32` the
/// wrong way would cull hits: the hierarchy finds exactly what testing every sphere does.
#[test]
fn grazing_rays_at_far_and_tiny_scales_agree_with_brute_force() {
    let mut r = Pcg32::new(33, 11);
    let mut stack = TraversalStack::default();
    for (offset, scale) in [(1e6, 30.0), (-3e6, 1.0), (0.0, 1e-6), (2e-6, 3e-8)] {
        let n = 400;
        let spheres: Vec<(DVec3, DVec3, f64)> = (0..n)
            .map(|i| {
                let c = DVec3::splat(offset)
                    + (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale;
                let v = if i % 2 == 0 {
                    DVec3::ZERO
                } else {
                    (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5) * scale * 0.1
                };
                (c, v, scale * (0.002 + r.next_f64() * 0.02))
            })
            .collect();
        let boxes_at = |s: f64| -> Vec<Aabb> {
            spheres
                .iter()
                .map(|(c, v, rad)| Aabb::point(*c + *v * s).grow(*rad).pad_for_rounding())
                .collect()
        };
        let still: Vec<(DVec3, f64)> = spheres.iter().map(|(c, _, rad)| (*c, *rad)).collect();
        let still_bvh = Bvh::build(&boxes_at(0.0));
        let moving_bvh = Bvh::build_moving(&boxes_at(0.0), &boxes_at(1.0));
        let mut hits = 0;
        for _ in 0..3000 {
            let (c, v, rad) = spheres[(r.next_f64() * n as f64) as usize];
            let time = if r.next_f64() < 0.5 {
                0.0
            } else {
                r.next_f64()
            };
            let moving = r.next_f64() < 0.5;
            let centre = if moving { c + v * time } else { c };
            // The ray touches the sphere where its box's face does (an axis-aligned
            // normal), or elsewhere; it runs along the tangent plane, shifted by a few
            // ulps of the coordinates either way.
            let axis = (r.next_f64() * 3.0) as usize;
            let mut normal = DVec3::ZERO;
            normal[axis] = if r.next_f64() < 0.5 { 1.0 } else { -1.0 };
            if r.next_f64() < 0.3 {
                normal = (DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5).normalize();
            }
            let tangent = normal
                .cross(DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) - 0.5)
                .normalize();
            let shift = (r.next_f64() - 0.5) * 8.0 * f64::EPSILON * (offset.abs() + scale);
            let touch = centre + normal * (rad + shift);
            let ray = crate::ray::Ray {
                origin: touch - tangent * (scale * (0.01 + r.next_f64())),
                dir: tangent,
                time,
            };
            if moving {
                assert!(moving_hit_is_brute(
                    moving_bvh.view(),
                    &spheres,
                    &ray,
                    &mut stack
                ));
            } else {
                let order = still_bvh.order();
                let got = still_bvh.closest_hit(
                    ray.origin,
                    ray.dir,
                    0.0,
                    f64::INFINITY,
                    &mut stack,
                    |p, tmax| {
                        let (c, rad) = still[order[p as usize] as usize];
                        crate::sphere::intersect(c, rad, &ray, tmax)
                    },
                );
                let want = brute(&still, &ray);
                hits += want.is_some() as usize;
                assert_eq!(got.map(|(t, p)| (t, order[p as usize])), want);
            }
        }
        // Grazing rays hit about half the time: the test is not vacuous.
        assert!(hits > 100, "{hits} hits at scale {scale}");
    }
}

/// The primitives a traversal visits (position, `t_max` bits) and the hit it finds.
type Visits = (Vec<(u32, u64)>, Option<(f64, u32)>);

/// Every kernel of the traversal (plain arrays; SSE and, where the processor has it, AVX on
/// x86-64) visits the same primitives in the same order with the same distance bounds, and
/// finds the same hit: their lanes give the same bits, so a render is the same bytes on any
/// of them. Still, moving, refitted and compact hierarchies; rays of every kind `random_rays`
/// makes.
#[test]
fn every_kernel_visits_the_same_primitives() {
    use super::lanes::{Lanes, Plain};
    let mut r = Pcg32::new(14, 2);
    let mut stack = TraversalStack::default();
    /// The primitives `view` visits along `ray` on machine `m` (position and `t_max` bits),
    /// and the hit.
    fn visits<M: Lanes>(
        m: M,
        view: BvhView,
        spheres: &[(DVec3, DVec3, f64)],
        ray: &crate::ray::Ray,
        stack: &mut TraversalStack,
    ) -> Visits {
        let order = view.topology.order();
        let mut seen = vec![];
        let got = view.closest_hit_on(
            m,
            ray.origin,
            ray.dir,
            ray.time,
            f64::INFINITY,
            stack,
            &mut |p: u32, t_max: f64| {
                seen.push((p, t_max.to_bits()));
                let (c, v, rad) = spheres[order[p as usize] as usize];
                crate::sphere::intersect(c + v * ray.time, rad, ray, t_max)
            },
        );
        (seen, got)
    }
    let mut compared = 0;
    for &n in &[1usize, 9, 64, 700, 5000] {
        let (spheres, open, close) = moving_spheres(&mut r, n);
        let moving = Bvh::build_moving(&open, &close);
        let (_, open2, close2) = moving_spheres(&mut r, n);
        let refitted = moving.topology().refit_moving(&open2, &close2);
        let still_spheres: Vec<(DVec3, DVec3, f64)> = spheres
            .iter()
            .map(|&(c, _, rad)| (c, DVec3::ZERO, rad))
            .collect();
        let still = Bvh::build(&open);
        let compact = compact_boxes(&moving, &open, &close);
        let cases = [
            (moving.view(), &spheres),
            (BvhView::new(moving.topology(), &refitted), &spheres),
            (still.view(), &still_spheres),
            (BvhView::new(moving.topology(), &compact), &spheres),
        ];
        for ray in random_rays(&mut r, 1000) {
            for (view, spheres) in cases {
                let plain = visits(Plain, view, spheres, &ray, &mut stack);
                #[cfg(target_arch = "x86_64")]
                {
                    use super::lanes::{Avx, Sse, avx_where_available};
                    assert_eq!(visits(Sse, view, spheres, &ray, &mut stack), plain);
                    if let Some(v3) = avx_where_available() {
                        let avx = v3.vectorize(|| visits(Avx(v3), view, spheres, &ray, &mut stack));
                        assert_eq!(avx, plain);
                    }
                }
                compared += usize::from(!plain.0.is_empty());
            }
        }
    }
    // A fair share of the rays reach primitives.
    assert!(compared > 1500, "{compared}");
}

/// [`super::BYTES_PER_PRIMITIVE`] bounds a moving hierarchy's memory over random spheres, and
/// is not far above it (within a factor of two).
#[test]
fn bytes_per_primitive_bounds_a_moving_hierarchy() {
    let mut r = Pcg32::new(15, 4);
    for &n in &[100usize, 2000, 30_000] {
        let (_, open, close) = moving_spheres(&mut r, n);
        let bvh = Bvh::build_moving(&open, &close);
        let per = bvh.memory_bytes() as f64 / n as f64;
        assert!(per <= super::BYTES_PER_PRIMITIVE as f64, "{n}: {per}");
        assert!(per > 0.5 * super::BYTES_PER_PRIMITIVE as f64, "{n}: {per}");
    }
}

/// A packet of rays, and as many rays walking in turns, find, ray for ray, the hit each finds
/// alone: coherent packets (from
/// around one point towards around another, as a pixel's camera rays) and random ones, some
/// lanes with bounds on the distance, axis-parallel, tiny-direction or non-finite rays among
/// them, packets of one to eight rays; still, moving, refitted and compact hierarchies; every
/// kernel.
#[test]
fn packets_and_turns_find_what_each_ray_finds_alone() {
    use super::lanes::{Lanes, Plain};
    use super::stack::PACKET;
    let mut r = Pcg32::new(16, 6);
    let mut stack = TraversalStack::default();
    fn check<M: Lanes + Copy>(
        m: M,
        view: BvhView,
        spheres: &[(DVec3, DVec3, f64)],
        rays: &[crate::ray::Ray],
        t_max: [f64; PACKET],
        stack: &mut TraversalStack,
    ) -> usize {
        let (turns, hits) = turns_match_each_alone(m, view, spheres, rays, t_max, stack);
        let test = sphere_test(&view, spheres);
        let got = view.closest_hits_on(m, &lanes_of(rays), t_max, stack, |lane: usize, p, t| {
            test(&rays[lane], p, t)
        });
        assert_eq!(got, turns, "a packet");
        hits
    }
    let mut hits = 0;
    for &n in &[1usize, 9, 64, 700, 5000] {
        let (spheres, open, close) = moving_spheres(&mut r, n);
        let moving = Bvh::build_moving(&open, &close);
        let (_, open2, close2) = moving_spheres(&mut r, n);
        let refitted = moving.topology().refit_moving(&open2, &close2);
        let still_spheres: Vec<(DVec3, DVec3, f64)> = spheres
            .iter()
            .map(|&(c, _, rad)| (c, DVec3::ZERO, rad))
            .collect();
        let still = Bvh::build(&open);
        let compact = compact_boxes(&moving, &open, &close);
        let cases = [
            (moving.view(), &spheres),
            (BvhView::new(moving.topology(), &refitted), &spheres),
            (still.view(), &still_spheres),
            (BvhView::new(moving.topology(), &compact), &spheres),
        ];
        for round in 0..300 {
            let len = 1 + round % PACKET;
            let rays: Vec<crate::ray::Ray> = if round % 3 == 0 {
                random_rays(&mut r, len)
            } else {
                // Coherent: from within 0.1 of one point towards within 0.3 of another.
                let from = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 30.0 - 15.0;
                let to = DVec3::new(r.next_f64(), r.next_f64(), r.next_f64()) * 16.0 - 8.0;
                (0..len)
                    .map(|_| {
                        let jitter =
                            |r: &mut Pcg32| DVec3::new(r.next_f64(), r.next_f64(), r.next_f64());
                        let origin = from + (jitter(&mut r) - 0.5) * 0.2;
                        crate::ray::Ray {
                            origin,
                            dir: (to + (jitter(&mut r) - 0.5) * 0.6 - origin).normalize(),
                            time: r.next_f64(),
                        }
                    })
                    .collect()
            };
            let mut rays = rays;
            // Now and then a ray the `f32` test cannot take, or one that is not finite.
            if round % 7 == 3 {
                rays[0].dir = DVec3::new(1e-31, 1.0, 0.0).normalize();
            }
            if round % 11 == 5 {
                rays[len - 1].origin.x = f64::NAN;
            }
            let mut t_max = [f64::INFINITY; PACKET];
            if round % 2 == 1 {
                for t in t_max.iter_mut().take(len) {
                    *t = r.next_f64() * 30.0;
                }
            }
            for (view, spheres) in cases {
                hits += check(Plain, view, spheres, &rays, t_max, &mut stack);
                #[cfg(target_arch = "x86_64")]
                {
                    use super::lanes::{Avx, Sse, avx_where_available};
                    check(Sse, view, spheres, &rays, t_max, &mut stack);
                    if let Some(v3) = avx_where_available() {
                        v3.vectorize(|| check(Avx(v3), view, spheres, &rays, t_max, &mut stack));
                    }
                }
            }
        }
    }
    assert!(hits > 2000, "{hits}");
}

/// A stream of more rays than walks under way at once (up to 256 walking in turns of
/// [`TURNS`](super::stack::TURNS)) finds, ray for ray, the hit each finds alone: each walk
/// that ends hands its slot to the next ray, whatever their number, order or bounds; rays
/// the `f32` test cannot take and non-finite rays among them; moving and compact
/// hierarchies; every kernel.
#[test]
fn a_stream_of_walks_finds_what_each_ray_finds_alone() {
    use super::lanes::Plain;
    const N: usize = crate::bits::Bits::CAPACITY;
    let mut r = Pcg32::new(17, 7);
    let mut stack = TraversalStack::default();
    let mut hits = 0;
    let (spheres, open, close) = moving_spheres(&mut r, 3000);
    let moving = Bvh::build_moving(&open, &close);
    let compact = compact_boxes(&moving, &open, &close);
    for round in 0..60 {
        let len = 1 + (round * 13) % N;
        let mut rays = random_rays(&mut r, len);
        if round % 5 == 2 {
            rays[len / 2].dir = DVec3::new(1e-31, 1.0, 0.0).normalize();
        }
        if round % 7 == 3 {
            rays[len - 1].origin.y = f64::INFINITY;
        }
        let mut t_max = [f64::INFINITY; N];
        if round % 2 == 1 {
            for t in t_max.iter_mut().take(len) {
                *t = r.next_f64() * 30.0;
            }
        }
        for view in [moving.view(), BvhView::new(moving.topology(), &compact)] {
            hits += turns_match_each_alone(Plain, view, &spheres, &rays, t_max, &mut stack).1;
            #[cfg(target_arch = "x86_64")]
            {
                use super::lanes::{Avx, Sse, avx_where_available};
                turns_match_each_alone(Sse, view, &spheres, &rays, t_max, &mut stack);
                if let Some(v3) = avx_where_available() {
                    v3.vectorize(|| {
                        turns_match_each_alone(Avx(v3), view, &spheres, &rays, t_max, &mut stack)
                    });
                }
            }
        }
    }
    assert!(hits > 500, "{hits}");
}

/// The primitive test of these tests' hierarchies: a ray against the sphere at leaf position
/// `p` of `view` (`spheres[order[p]]`: its centre moved by its velocity to the ray's time).
fn sphere_test<'a>(
    view: &BvhView<'a>,
    spheres: &'a [(DVec3, DVec3, f64)],
) -> impl Fn(&crate::ray::Ray, u32, f64) -> Option<f64> + 'a {
    let order = view.topology.order();
    move |ray, p, t| {
        let (c, v, rad) = spheres[order[p as usize] as usize];
        crate::sphere::intersect(c + v * ray.time, rad, ray, t)
    }
}

/// `rays` as a packet's lanes or walks in turns take them (a ray's time its shutter fraction).
fn lanes_of(rays: &[crate::ray::Ray]) -> Vec<super::PacketRay> {
    rays.iter()
        .map(|ray| super::PacketRay {
            origin: ray.origin,
            dir: ray.dir,
            s: ray.time,
        })
        .collect()
}

/// Walks `rays` in turns on the lanes of `m` and checks each ray's hit against its walk alone
/// (and that rays past the last find nothing); returns the hits and how many rays hit.
fn turns_match_each_alone<M: super::lanes::Lanes + Copy, const N: usize>(
    m: M,
    view: BvhView,
    spheres: &[(DVec3, DVec3, f64)],
    rays: &[crate::ray::Ray],
    t_max: [f64; N],
    stack: &mut TraversalStack,
) -> ([Option<(f64, u32)>; N], usize) {
    let test = sphere_test(&view, spheres);
    let turns =
        view.closest_hits_in_turns_on(m, &lanes_of(rays), t_max, stack, |r: usize, p, t| {
            test(&rays[r], p, t)
        });
    let mut hits = 0;
    for (r, ray) in rays.iter().enumerate() {
        let alone = view.closest_hit_on(
            m,
            ray.origin,
            ray.dir,
            ray.time,
            t_max[r],
            stack,
            &mut |p: u32, t: f64| test(ray, p, t),
        );
        assert_eq!(turns[r], alone, "ray {r} of {}: {ray:?}", rays.len());
        hits += usize::from(alone.is_some());
    }
    assert!(turns[rays.len()..].iter().all(Option::is_none));
    (turns, hits)
}
