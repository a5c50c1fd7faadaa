/* Exact regular tracking (lib/transport/walk.h) against a brute-force
 * reference: every face crossing of a straight ray found axis by axis and
 * sorted. A free flight must end where the reference's optical depth
 * reaches the sampled depth, and log one segment per voxel crossed, of the
 * reference's length, in the reference's voxel (the gradient's scores
 * need exactly these). Heterogeneous grids with vacuum voxels, random rays
 * and rays along the axes on voxel faces and edges (a pencil beam's first
 * flight); walks to the boundary along an axis by their optical-depth
 * table against the same rays walked; the uniform fast path against the
 * same grid stepped; the split of a path's logged rays, each started
 * where the last one ended; and a flight's entry carrying its vertex's
 * phase score, applied as the two entries it replaces.
 * Runs in well under a second. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "test_support.h"
#include "tracking_reference.h"

#include "medium/medium_internal.h"
#include "sampling/geometry.h"
#include "transport/grid.h"
#include "transport/tracer.h"
#include "transport/walk.h"

enum { RAYS = 4000 };

/* The same box with equal voxels: a uniform grid (the fast path). */
static void uniform_fixture_make(fixture_t *f) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  const int32_t dims[3] = {NX, NY, NZ};
  assert_ok(hetinv_medium_create(f->ctx, LO, HI, dims, &f->medium));
  assert_ok(hetinv_medium_fill(f->medium, 0.7, 3.1, 0.4));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hv_grid_build(f->medium, NULL, &f->grid));
  assert_true(f->grid.uniform);
}

/* The logged segments, zero-length ones dropped, must be the reference's. */
static void check_log(const hv_path_log_t *log, const seg_t *ref, int ref_count, int ray) {
  int j = 0;
  for (size_t i = 0; i < log->count; ++i) {
    const hv_log_entry_t *e = &log->entries[i];
    assert_int_equal(e->kind, HV_LOG_SEGMENT);
    if (e->u.at.value < 1e-12) continue;
    if (j >= ref_count || e->u.at.voxel != ref[j].k || fabs(e->u.at.value - ref[j].length) > 1e-12) {
      print_error("ray %d, segment %d: voxel %lld length %.17g, reference voxel %lld length %.17g\n",
                  ray, j, (long long)e->u.at.voxel, e->u.at.value,
                  j < ref_count ? (long long)ref[j].k : -1LL, j < ref_count ? ref[j].length : 0.0);
      fail();
    }
    ++j;
  }
  if (j != ref_count) {
    print_error("ray %d: %d segments logged, reference has %d\n", ray, j, ref_count);
    fail();
  }
}

/* One flight from p along d over optical depth `depth`, checked against the
 * reference: end point, distance, voxel, segments. */
static void check_flight(const fixture_t *f, hv_path_log_t *log, const double p[3],
                         const double d[3], double depth, int ray) {
  const hv_grid_t *g = &f->grid;
  hv_ray_t r = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}};
  hv_ray_locate(g, &r);
  seg_t ref[MAX_SEG];
  double t_exit = exit_distance(g, p, d);
  int n = reference_segments(g, p, d, t_exit, ref);
  /* Where the reference reaches the depth, if it does. */
  double acc = 0.0, t = 0.0, t_ref = t_exit;
  int last = n;
  bool hit = false;
  for (int i = 0; i < n; ++i) {
    double tau = g->voxel[ref[i].k].sigma_t * ref[i].length;
    if (acc + tau >= depth) {
      t_ref = t + (depth - acc) / g->voxel[ref[i].k].sigma_t;
      ref[i].length = t_ref - t;
      last = i + 1;
      hit = true;
      break;
    }
    acc += tau;
    t += ref[i].length;
  }
  hv_path_log_reset(log);
  double dist = -1.0;
  hetinv_face_t face = HETINV_FACE_X_MIN;
  int collided = hv_ray_march(g, &r, depth, &dist, &face, log);
  if (collided != hit ||
      fabs(dist - t_ref) > 1e-11 * (1.0 + t_ref)) {
    print_error("ray %d: collided %d at %.17g, reference %.17g (exit at %.17g)\n", ray, collided,
                dist, t_ref, t_exit);
    fail();
  }
  check_log(log, ref, last, ray);
  for (int a = 0; a < 3; ++a) assert_true(fabs(r.p[a] - (p[a] + dist * d[a])) < 1e-11);
  if (collided) {
    /* r.k is a voxel whose closed box holds the collision point. */
    for (int a = 0; a < 3; ++a) {
      int32_t v = (int32_t)((r.k / g->stride[a]) % g->n[a]);
      assert_true(r.p[a] >= g->face[a][v] - 1e-12 && r.p[a] <= g->face[a][v + 1] + 1e-12);
    }
  } else {
    int a = hv_face_axis(face);
    assert_true(r.p[a] == ((int)face & 1 ? g->hi[a] : g->lo[a]));
  }
}

static hv_path_log_t make_log(const fixture_t *f) {
  return (hv_path_log_t){.ctx = f->ctx};
}

static void random_flights_match_reference(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x243f6a8885a308d3);
  fixture_t f;
  fixture_make(&f, &seed);
  hv_path_log_t log = make_log(&f);
  for (int i = 0; i < RAYS; ++i) {
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * uniform(&seed);
    random_direction(&seed, d);
    /* From a fraction of a voxel to across the box. */
    double depth = 1e-9 - log1p(-uniform(&seed)) * (i % 2 ? 0.5 : 8.0);
    check_flight(&f, &log, p, d, depth, i);
  }
  assert_false(log.out_of_memory);
  hv_path_log_release(&log);
  fixture_free(&f);
}

/* A pencil beam: axis-parallel directions (±0 components), starting on a
 * boundary face at a point on voxel faces of the other axes. */
static void axis_rays_on_faces_match_reference(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x13198a2e03707344);
  fixture_t f;
  fixture_make(&f, &seed);
  hv_path_log_t log = make_log(&f);
  int ray = 0;
  for (int a = 0; a < 3; ++a) {
    for (int sign = -1; sign <= 1; sign += 2) {
      for (int i = 0; i < 40; ++i, ++ray) {
        double p[3], d[3] = {i % 2 ? -0.0 : 0.0, i % 3 ? -0.0 : 0.0, i % 5 ? 0.0 : -0.0};
        d[a] = sign;
        for (int b = 0; b < 3; ++b) {
          int32_t v = (int32_t)(next_u64(&seed) % (uint64_t)(f.grid.n[b] + 1));
          p[b] = i % 4 ? f.grid.face[b][v] : LO[b] + (HI[b] - LO[b]) * uniform(&seed);
        }
        p[a] = sign > 0 ? LO[a] : HI[a];
        double depth = 1e-9 - log1p(-uniform(&seed)) * 4.0;
        check_flight(&f, &log, p, d, depth, ray);
      }
    }
  }
  hv_path_log_release(&log);
  fixture_free(&f);
}

/* hv_ray_to_boundary: the optical depth and segments to the boundary. */
static void rays_to_boundary_match_reference(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0xa4093822299f31d0);
  fixture_t f;
  fixture_make(&f, &seed);
  const hv_grid_t *g = &f.grid;
  hv_path_log_t log = make_log(&f);
  for (int i = 0; i < RAYS / 4; ++i) {
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * uniform(&seed);
    random_direction(&seed, d);
    seg_t ref[MAX_SEG];
    double t_exit = exit_distance(g, p, d);
    int n = reference_segments(g, p, d, t_exit, ref);
    double depth_ref = 0.0;
    for (int j = 0; j < n; ++j) depth_ref += g->voxel[ref[j].k].sigma_t * ref[j].length;
    hv_ray_t r = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}};
    hv_ray_locate(g, &r);
    hv_path_log_reset(&log);
    double dist;
    hetinv_face_t face;
    double depth = hv_ray_to_boundary(g, &r, &dist, &face, &log);
    assert_true(fabs(dist - t_exit) < 1e-11);
    assert_true(fabs(depth - depth_ref) < 1e-10 * (1.0 + depth_ref));
    check_log(&log, ref, n, i);
  }
  hv_path_log_release(&log);
  fixture_free(&f);
}

/* hv_ray_to_boundary along an axis with its optical-depth table built (one
 * lookup) against the same grid walked voxel by voxel, and both against the
 * reference: depth, distance, face, the end point and voxel, and the
 * segments logged. Rays start anywhere, on voxel faces and edges, and on
 * the box's faces, with ±0 components. */
static void axis_rays_to_boundary_match_walk(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x452821e638d01377);
  fixture_t f;
  fixture_make(&f, &seed);
  hv_grid_t walked = f.grid; /* the tables not built: every ray walks */
  assert_ok(hv_grid_build_axis_depths(&f.grid, 0x3fu));
  const hv_grid_t *g = &f.grid;
  for (int t = 0; t < 6; ++t) assert_non_null(g->axis_depth[t]);
  assert_null(walked.axis_depth[0]);
  hv_path_log_t log = make_log(&f), log_walked = make_log(&f);
  for (int i = 0; i < RAYS; ++i) {
    int a = i % 3, sign = (i / 3) % 2 ? 1 : -1;
    double p[3], d[3] = {i % 5 ? 0.0 : -0.0, i % 7 ? -0.0 : 0.0, i % 11 ? 0.0 : -0.0};
    d[a] = sign;
    for (int b = 0; b < 3; ++b) {
      int32_t v = (int32_t)(next_u64(&seed) % (uint64_t)(g->n[b] + 1));
      p[b] = i % 4 ? LO[b] + (HI[b] - LO[b]) * uniform(&seed) : g->face[b][v];
    }
    if (i % 9 == 0) p[a] = sign > 0 ? LO[a] : HI[a];
    seg_t ref[MAX_SEG];
    double t_exit = exit_distance(g, p, d);
    int n = reference_segments(g, p, d, t_exit, ref);
    double depth_ref = 0.0;
    for (int j = 0; j < n; ++j) depth_ref += g->voxel[ref[j].k].sigma_t * ref[j].length;
    hv_ray_t r = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}}, rw = r;
    hv_ray_locate(g, &r);
    hv_ray_locate(&walked, &rw);
    hv_path_log_reset(&log);
    hv_path_log_reset(&log_walked);
    double dist, dist_w;
    hetinv_face_t face, face_w;
    double depth = hv_ray_to_boundary(g, &r, &dist, &face, &log);
    double depth_w = hv_ray_to_boundary(&walked, &rw, &dist_w, &face_w, &log_walked);
    if (fabs(depth - depth_w) > 1e-12 * (1.0 + depth_w) || fabs(dist - dist_w) > 1e-12 ||
        face != face_w || r.k != rw.k || fabs(depth - depth_ref) > 1e-10 * (1.0 + depth_ref)) {
      print_error("ray %d: table depth %.17g dist %.17g face %d voxel %lld; walk %.17g %.17g %d %lld; "
                  "reference depth %.17g\n", i, depth, dist, (int)face, (long long)r.k, depth_w, dist_w,
                  (int)face_w, (long long)rw.k, depth_ref);
      fail();
    }
    for (int b = 0; b < 3; ++b) {
      assert_true(r.p[b] == rw.p[b]);
      assert_int_equal(r.v[b], rw.v[b]);
    }
    check_log(&log, ref, n, i);
    check_log(&log_walked, ref, n, i);
  }
  /* A ray off the axes still walks. */
  double d[3] = {0.6, 0.0, 0.8}, p[3] = {0.1, 0.5, 2.5};
  hv_ray_t r = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}};
  hv_ray_locate(g, &r);
  seg_t ref[MAX_SEG];
  int n = reference_segments(g, p, d, exit_distance(g, p, d), ref);
  double dist;
  hetinv_face_t face;
  hv_path_log_reset(&log);
  hv_ray_to_boundary(g, &r, &dist, &face, &log);
  check_log(&log, ref, n, -1);
  hv_path_log_release(&log);
  hv_path_log_release(&log_walked);
  fixture_free(&f);
}

/* A grid of equal voxels takes the uniform fast path (one multiplication
 * per flight, no stepping); the same grid stepped voxel by voxel must end
 * every flight at the same point, on the same face, over the same
 * distance, and give the same optical depth to the boundary. */
static void uniform_grid_matches_stepped(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x082efa98ec4e6c89);
  fixture_t f;
  uniform_fixture_make(&f);
  hv_grid_t fast = f.grid;
  hv_grid_t stepped = fast; /* the same voxels, walked one by one */
  stepped.uniform = 0;
  for (int i = 0; i < RAYS; ++i) {
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * uniform(&seed);
    if (i % 4 == 0) { /* on voxel faces, along an axis: an edge of the grid */
      for (int a = 0; a < 3; ++a) p[a] = fast.face[a][next_u64(&seed) % (uint64_t)(fast.n[a] + 1)];
      for (int a = 0; a < 3; ++a) d[a] = 0.0;
      d[i / 4 % 3] = i % 8 ? 1.0 : -1.0;
    } else {
      random_direction(&seed, d);
    }
    double depth = 1e-9 - log1p(-uniform(&seed)) * (i % 2 ? 0.5 : 8.0);
    hv_ray_t rf = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}}, rs = rf;
    hv_ray_locate(&fast, &rf);
    hv_ray_locate(&stepped, &rs);
    double df = -1.0, ds = -1.0;
    hetinv_face_t ff = HETINV_FACE_X_MIN, fs = HETINV_FACE_X_MIN;
    int cf = hv_ray_march(&fast, &rf, depth, &df, &ff, NULL);
    int cs = hv_ray_march(&stepped, &rs, depth, &ds, &fs, NULL);
    if (cf != cs || fabs(df - ds) > 1e-12 * (1.0 + ds) || (!cf && ff != fs)) {
      print_error("ray %d: uniform %d at %.17g (face %d), stepped %d at %.17g (face %d)\n", i, cf, df, (int)ff, cs,
                  ds, (int)fs);
      fail();
    }
    for (int a = 0; a < 3; ++a) assert_true(fabs(rf.p[a] - rs.p[a]) < 1e-12 * (1.0 + fabs(rs.p[a])));
    hv_ray_t bf = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}}, bs = bf;
    hv_ray_locate(&fast, &bf);
    hv_ray_locate(&stepped, &bs);
    double tf = hv_ray_to_boundary(&fast, &bf, &df, &ff, NULL);
    double ts = hv_ray_to_boundary(&stepped, &bs, &ds, &fs, NULL);
    assert_true(fabs(tf - ts) <= 1e-12 * (1.0 + ts) && fabs(df - ds) <= 1e-12 * (1.0 + ds) && ff == fs);
  }
  fixture_free(&f);
}

typedef struct visits {
  seg_t seg[MAX_SEG];
  int count;
} visits_t;

static void record_visit(void *user, int64_t k, double length) {
  visits_t *v = user;
  if (length < 1e-12) return; /* the reference drops zero-length pieces */
  assert_true(v->count < MAX_SEG);
  v->seg[v->count++] = (seg_t){k, length};
}

/* The gradient pass splits a path's logged rays (uniform grids) with
 * hv_walk_log_ray, which starts each ray in the voxel where the last one
 * ended instead of locating it. Paths of random flights in a uniform grid,
 * reflected at the boundary, some axis-parallel on voxel faces (a pencil
 * beam): every ray's split must be the reference's, and the voxel where it
 * ends must hold its end point. */
static void continuous_log_rays_split_as_reference(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x452821e638d01377);
  fixture_t f;
  uniform_fixture_make(&f);
  const hv_grid_t g = f.grid;
  hv_path_log_t log = make_log(&f);
  int rays = 0;
  for (int path = 0; path < 200; ++path) {
    hv_path_log_reset(&log);
    hv_ray_t r;
    bool beam = path % 4 == 0; /* axis-parallel, starting on voxel faces */
    for (int a = 0; a < 3; ++a) {
      r.p[a] = beam ? g.face[a][next_u64(&seed) % (uint64_t)(g.n[a] + 1)]
                    : LO[a] + (HI[a] - LO[a]) * uniform(&seed);
      r.d[a] = 0.0;
    }
    if (beam) {
      r.d[path / 4 % 3] = path % 8 ? 1.0 : -1.0;
    } else {
      random_direction(&seed, r.d);
    }
    hv_ray_locate(&g, &r);
    for (int flight = 0; flight < 40; ++flight) {
      double depth = 1e-9 - log1p(-uniform(&seed)) * (flight % 3 ? 1.0 : 6.0), dist;
      hetinv_face_t face;
      int collided = hv_ray_march(&g, &r, depth, &dist, &face, &log);
      if (collided) {
        if (!beam || flight % 2) random_direction(&seed, r.d); /* beams go on straight at times */
      } else {
        r.d[hv_face_axis(face)] = -r.d[hv_face_axis(face)]; /* reflected */
      }
    }
    assert_false(log.out_of_memory);
    hv_ray_t end = {.k = -1};
    for (size_t i = 0; i < log.count; ++i, ++rays) {
      const hv_log_entry_t *e = &log.entries[i];
      assert_int_equal(e->kind, HV_LOG_RAY);
      visits_t got = {.count = 0};
      int64_t k = hv_walk_log_ray(&g, e, &end, record_visit, &got);
      assert_true(k == end.k);
      seg_t ref[MAX_SEG];
      int n = reference_segments(&g, e->u.ray.p, e->u.ray.d, e->u.ray.length, ref);
      bool same = n == got.count;
      for (int j = 0; same && j < n; ++j) {
        same = ref[j].k == got.seg[j].k && fabs(ref[j].length - got.seg[j].length) <= 1e-12;
      }
      if (!same) {
        print_error("path %d, ray %zu: %d pieces, reference %d\n", path, i, got.count, n);
        fail();
      }
      for (int a = 0; a < 3; ++a) {
        double q = e->u.ray.p[a] + e->u.ray.length * e->u.ray.d[a];
        int32_t v = end.v[a];
        assert_true(end.k / g.stride[a] % g.n[a] == v);
        assert_true(q >= g.face[a][v] - 1e-12 && q <= g.face[a][v + 1] + 1e-12);
      }
    }
  }
  assert_true(rays == 200 * 40);
  hv_path_log_release(&log);
  fixture_free(&f);
}

/* A gradient tally over every voxel of g. */
typedef struct grad_arrays {
  double grad[3 * NX * NY * NZ];
  uint8_t touched[NX * NY * NZ];
  int64_t touched_list[NX * NY * NZ];
  hv_grad_tally_t gt;
} grad_arrays_t;

static void grad_arrays_init(grad_arrays_t *a) {
  memset(a, 0, sizeof *a);
  a->gt = (hv_grad_tally_t){.grad = a->grad, .voxels = NX * NY * NZ, .touched = a->touched,
                            .touched_list = a->touched_list};
}

/* hv_path_log_set_ray_vertex folds a vertex's σs and phase scores into
 * the flight that ends there. Applied, it must give bitwise what the two
 * entries it replaces give (the flight marked by set_ray_scatter, then a
 * PHASE entry at the vertex with the same running total): paths of
 * straight flights ending inside a grid whose σa, σs and g differ per
 * voxel, each path split from its first flight's located voxel on. */
static void ray_vertex_entry_applies_as_its_two_entries(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x13198a2e03707344);
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  assert_ok(hetinv_context_create(&init, &ctx));
  const int32_t dims[3] = {NX, NY, NZ};
  assert_ok(hetinv_medium_create(ctx, LO, HI, dims, &medium));
  enum { N = NX * NY * NZ };
  double sa[N], ss[N], gg[N];
  for (int i = 0; i < N; ++i) {
    sa[i] = 0.1 + 2.0 * uniform(&seed);
    ss[i] = 0.1 + 8.0 * uniform(&seed);
    gg[i] = -0.9 + 1.8 * uniform(&seed); /* both forms of the HG score */
  }
  assert_ok(hetinv_medium_set_grid(medium, HETINV_PARAM_SIGMA_A, sa, N));
  assert_ok(hetinv_medium_set_grid(medium, HETINV_PARAM_SIGMA_S, ss, N));
  assert_ok(hetinv_medium_set_grid(medium, HETINV_PARAM_G, gg, N));
  assert_ok(hetinv_medium_commit(medium));
  hv_grid_t g;
  assert_ok(hv_grid_build(medium, NULL, &g));
  grad_arrays_t *two = test_malloc(sizeof *two), *one = test_malloc(sizeof *one);
  grad_arrays_init(two);
  grad_arrays_init(one);
  hv_path_log_t log_two = {.ctx = ctx}, log_one = {.ctx = ctx};
  for (int path = 0; path < 300; ++path) {
    hv_path_log_reset(&log_two);
    hv_path_log_reset(&log_one);
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * uniform(&seed);
    random_direction(&seed, d);
    for (int flight = 0; flight < 30; ++flight) {
      double length = uniform(&seed) * exit_distance(&g, p, d), cos_theta = 2.0 * uniform(&seed) - 1.0;
      hv_path_log_add_ray(&log_two, p, d, length);
      hv_path_log_add_ray(&log_one, p, d, length);
      for (int a = 0; a < 3; ++a) p[a] += length * d[a];
      hv_path_log_set_ray_scatter(&log_two);
      hv_path_log_add_at(&log_two, HV_LOG_PHASE, p, cos_theta); /* the voxel the ray ended in */
      hv_path_log_set_ray_vertex(&log_one, cos_theta);
      random_direction(&seed, d);
    }
    assert_int_equal(log_one.count, 30);
    assert_int_equal(log_two.count, 60);
    log_two.cum = log_one.cum = 0.5 + uniform(&seed); /* the path's splat total */
    log_two.scored = log_one.scored = true;
    hv_grad_apply_log(&two->gt, &g, &log_two);
    hv_grad_apply_log(&one->gt, &g, &log_one);
  }
  assert_false(log_two.out_of_memory || log_one.out_of_memory);
  assert_memory_equal(two->grad, one->grad, sizeof two->grad);
  assert_int_equal(two->gt.touched_count, one->gt.touched_count);
  assert_memory_equal(two->touched_list, one->touched_list, two->gt.touched_count * sizeof two->touched_list[0]);
  double g_norm = 0.0;
  for (int k = 0; k < N; ++k) g_norm += fabs(one->grad[2 * N + k]);
  assert_true(g_norm > 0.0); /* the phase scores were added */
  hv_path_log_release(&log_two);
  hv_path_log_release(&log_one);
  test_free(two);
  test_free(one);
  hv_grid_release(&g);
  hetinv_medium_destroy(&medium);
  hetinv_context_destroy(&ctx);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(random_flights_match_reference),
      cmocka_unit_test(axis_rays_on_faces_match_reference),
      cmocka_unit_test(rays_to_boundary_match_reference),
      cmocka_unit_test(axis_rays_to_boundary_match_walk),
      cmocka_unit_test(uniform_grid_matches_stepped),
      cmocka_unit_test(continuous_log_rays_split_as_reference),
      cmocka_unit_test(ray_vertex_entry_applies_as_its_two_entries),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
