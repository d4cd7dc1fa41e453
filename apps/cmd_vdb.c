/* morsegs vdb SCENE.ply -o OUT.vdb: any 3DGS .ply -> a .vdb with grids
 *   density  fog volume: the α-field clamped to [0,1] (0 outside; what the splats define)
 *   sdf      level set of {A = τ}: negative inside, world units, band ±W voxels
 * plus file metadata (tool, version, tau, voxel_size, source) and, with --mesh, the zero
 * level set as a PLY/OBJ mesh. Never overwrites without --force.
 * morsegs vdb RUN -o OUT.vdb (a run folder), or --from-depth: the SDF from the model's
 * rendered depth fused at the run's cameras (measure/mgs_depth_fusion.h) is `sdf` (the first
 * level set: what `persistence` and --mesh take), with the fusion's `tsdf` and
 * `tsdf_weight`, and the α-field's grids beside it as `density` and `sdf_alpha`
 * (docs/notes/depth-fusion.md: why this is the default for run folders) — unless the
 * α-field's surface agrees better with the renders (measure/mgs_surface_choice.h): then it
 * is `sdf` and the fused one `sdf_fused`. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "apps/mgs_cli.h"
#include "measure/mgs_depth_fusion.h"
#include "measure/mgs_surface_choice.h"
#include "core/mgs_fs.h"
#include "core/mgs_log.h"
#include "core/mgs_mesh.h"
#include "core/mgs_ply.h"
#include "vdb/mgs_vdb.h"
#include "train/mgs_sugar.h"

static void usage(FILE *f) {
  fprintf(f,
          "usage: morsegs vdb SCENE.ply|RUN -o OUT.vdb [options]\n"
          "  -o, --output OUT.vdb     output file (grids 'density' and 'sdf')\n"
          "  SCENE.ply (3DGS or 2DGS .ply; also SuperSplat's .compressed.ply, a .splat, a .spz, a .sog or\n"
          "  its meta.json, a .ksplat): the alpha-field's surface (density, sdf); RUN (a run folder): the surface\n"
          "  of the rendered depth fused at RUN/cameras.json as sdf (tsdf, tsdf_weight beside it)\n"
          "  plus the alpha-field's as density and sdf_alpha; where the alpha-field's surface agrees better\n"
          "  with the model's renders (parts a few pixels thick) it is sdf and the fused one sdf_fused\n"
          "  --surface auto|fused|alpha  run folder: which surface is sdf (and --mesh) (auto: the one\n"
          "                           closer to the views' rendered depth, both directions)\n"
          "  --from-depth             depth fusion also for a bare .ply (virtual views)\n"
          "  --from-alpha             the alpha-field's surface only, also for a run folder\n"
          "  --no-alpha               depth fusion without the alpha-field's grids\n"
          "  --iteration N            run folder: point_cloud/iteration_N (default: the latest)\n"
          "  --views N                virtual views when there is no cameras.json (64)\n"
          "  --view-size PX           their side in pixels (256): the fusion voxel follows it\n"
          "  --depth median|expected  depth map fused (default: the model's, median for 3DGS)\n"
          "  --fuse-voxel F           fusion voxel size in pixel footprints of the views (1)\n"
          "  --trunc F                truncation in pixel footprints (9)\n"
          "  --trunc-thin F           thin parts: a second fusion at F footprints where the wide one merges\n"
          "                           two sides of a part (2; 0 = off)\n"
          "  --fuse-voxel-size H, --trunc-size T   the same in world units (override)\n"
          "  --min-weight W           views a voxel needs to count as observed (1)\n"
          "  --carve                  background pixels carve free space (off: it erodes surfaces)\n"
          "  --mask-carve PX|off      pixels PX or more outside the dataset images' silhouettes carve free\n"
          "                           space (4): floaters seen through the model are not fused\n"
          "  --resolution R           voxels along the diagonal of the means' bounding box (256)\n"
          "  --voxel-size H           absolute voxel size (overrides --resolution)\n"
          "  --tau T                  iso value of the surface {A = T} (0.5)\n"
          "  --band W                 narrow-band half-width in voxels (3)\n"
          "  --k-sigma K              each Gaussian covers K standard deviations (3)\n"
          "  --small peak|mass|none   sub-voxel Gaussians: low-pass keeping the peak (default),\n"
          "                           mass-preserving low-pass, or none\n"
          "  --sdf-method closest|mesh|sweep  closest points on {A = T} carried through the band\n"
          "                           (default), volumeToMesh+meshToLevelSet, or fast sweeping\n"
          "  --mem-budget GB          refuse builds estimated above this (default 60%% of RAM)\n"
          "  --mesh OUT.ply|OUT.obj   also write the zero level set as a triangle mesh\n"
          "  --adaptivity A           mesh simplification in [0,1] (0)\n"
          "  --force                  overwrite existing outputs\n"
          "  morsegs vdb RUN --sugar-mesh: SuGaR's mesh of the run (level crossings of its density along the\n"
          "  training rays, CGAL Poisson, trimming, decimation) -> RUN/mesh/sugar.ply and its level set\n"
          "  RUN/mesh/sugar.vdb (grid sdf, voxel = the mesh's diagonal / --resolution); with\n"
          "  --sugar-level L (0.3), --sugar-points N per view (0: every pixel), --sugar-trim Q (0.1),\n"
          "  --sugar-triangles N (200000), --iteration, --force\n");
}

static int parse_double(const char *s, double *v) {
  char *end = NULL;
  *v = strtod(s, &end);
  return end && end != s && *end == 0 && isfinite(*v);
}

/* Library messages about the build ("alpha field: ...") get the input file in front. */
static void name_input(mgs_error *err, const char *in) {
  char tmp[MGS_ERROR_MSG_MAX];
  snprintf(tmp, sizeof tmp, "%s", err->msg);
  mgs_error_set(err, err->code, "%s: %s", in, tmp);
}

int mgs_cmd_vdb(int argc, char **argv) {
  static const struct option opts[] = {
      {"output", required_argument, 0, 'o'},      {"resolution", required_argument, 0, 'r'},
      {"voxel-size", required_argument, 0, 'h'},  {"tau", required_argument, 0, 't'},
      {"band", required_argument, 0, 'b'},        {"k-sigma", required_argument, 0, 'k'},
      {"mesh", required_argument, 0, 'm'},        {"adaptivity", required_argument, 0, 'a'},
      {"force", no_argument, 0, 'f'},             {"small", required_argument, 0, 's'},
      {"sdf-method", required_argument, 0, 'M'},  {"mem-budget", required_argument, 0, 'B'},
      {"from-depth", no_argument, 0, 'D'},       {"from-alpha", no_argument, 0, 'A'},
      {"no-alpha", no_argument, 0, 'N'},         {"iteration", required_argument, 0, 'I'},
      {"views", required_argument, 0, 'V'},      {"depth", required_argument, 0, 'Z'},
      {"view-size", required_argument, 0, 1002},
      {"fuse-voxel", required_argument, 0, 'x'}, {"trunc", required_argument, 0, 'T'},
      {"trunc-thin", required_argument, 0, 'K'},
      {"fuse-voxel-size", required_argument, 0, 'X'}, {"trunc-size", required_argument, 0, 'S'},
      {"min-weight", required_argument, 0, 'W'}, {"carve", no_argument, 0, 'C'}, {"mask-carve", required_argument, 0, 1001},
      {"sugar-mesh", no_argument, 0, 'g'},       {"sugar-level", required_argument, 0, 'l'},
      {"sugar-points", required_argument, 0, 'p'}, {"sugar-triangles", required_argument, 0, 'q'},
      {"sugar-trim", required_argument, 0, 'u'}, {"surface", required_argument, 0, 'j'},
      {"help", no_argument, 0, 'H'},              {0, 0, 0, 0}};
  const char *out = NULL, *mesh_out = NULL;
  mgs_vdb_alpha_params ap;
  mgs_vdb_alpha_params_default(&ap);
  mgs_vdb_sdf_params sp;
  mgs_vdb_sdf_params_default(&sp);
  double adaptivity = 0, v = 0;
  int force = 0, c, from_depth = 0, from_alpha = 0, no_alpha = 0;
  int surface = -1; /* -1 auto, 0 fused, 1 alpha */
  mgs_fusion_opts fo;
  mgs_fusion_opts_default(&fo);
  int sugar = 0;
  mgs_sugar_mesh_options so;
  mgs_sugar_mesh_options_default(&so);
  optind = 1;
  while ((c = getopt_long(argc, argv, "o:", opts, NULL)) != -1) {
    switch (c) {
      case 'o': out = optarg; break;
      case 'r':
        if (!parse_double(optarg, &v) || v < 1 || v > 1e6 || v != floor(v)) {
          fprintf(stderr, "morsegs vdb: --resolution '%s' must be an integer in [1, 1e6]\n", optarg);
          return 2;
        }
        ap.resolution = (int)v;
        break;
      case 'h':
        if (!parse_double(optarg, &ap.voxel_size) || ap.voxel_size <= 0) {
          fprintf(stderr, "morsegs vdb: --voxel-size '%s' must be a positive number\n", optarg);
          return 2;
        }
        break;
      case 't':
        if (!parse_double(optarg, &sp.tau) || sp.tau <= 0) {
          fprintf(stderr, "morsegs vdb: --tau '%s' must be a positive number\n", optarg);
          return 2;
        }
        break;
      case 'b':
        if (!parse_double(optarg, &v) || v < 1 || v > 1000 || v != floor(v)) {
          fprintf(stderr, "morsegs vdb: --band '%s' must be an integer in [1, 1000]\n", optarg);
          return 2;
        }
        sp.half_width = ap.half_width = (int)v;
        break;
      case 'k':
        if (!parse_double(optarg, &ap.k_sigma) || ap.k_sigma <= 0 || ap.k_sigma > 10) {
          fprintf(stderr, "morsegs vdb: --k-sigma '%s' must be in (0, 10]\n", optarg);
          return 2;
        }
        break;
      case 'm': mesh_out = optarg; break;
      case 'a':
        if (!parse_double(optarg, &adaptivity) || adaptivity < 0 || adaptivity > 1) {
          fprintf(stderr, "morsegs vdb: --adaptivity '%s' must be in [0, 1]\n", optarg);
          return 2;
        }
        break;
      case 'f': force = 1; break;
      case 's':
        if (!strcmp(optarg, "mass")) ap.small = MGS_VDB_SMALL_MASS;
        else if (!strcmp(optarg, "peak")) ap.small = MGS_VDB_SMALL_PEAK;
        else if (!strcmp(optarg, "none")) ap.small = MGS_VDB_SMALL_NONE;
        else { fprintf(stderr, "morsegs vdb: --small '%s': expected mass, peak or none\n", optarg); return 2; }
        break;
      case 'M':
        if (!strcmp(optarg, "mesh")) sp.method = MGS_VDB_SDF_MESH;
        else if (!strcmp(optarg, "sweep")) sp.method = MGS_VDB_SDF_SWEEP;
        else if (!strcmp(optarg, "closest")) sp.method = MGS_VDB_SDF_CLOSEST;
        else { fprintf(stderr, "morsegs vdb: --sdf-method '%s': expected closest, mesh or sweep\n", optarg); return 2; }
        break;
      case 'B':
        if (!parse_double(optarg, &v) || v <= 0) {
          fprintf(stderr, "morsegs vdb: --mem-budget '%s' must be a positive number of GB\n", optarg);
          return 2;
        }
        ap.memory_budget = v * 1e9;
        break;
      case 'D': from_depth = 1; break;
      case 'C': fo.carve = 1; break;
      case 1001:
        if (!mgs_cli_mask_carve("vdb", optarg, &fo.mask_carve_px)) return 2;
        break;
      case 'A': from_alpha = 1; break;
      case 'N': no_alpha = 1; break;
      case 'j':
        if (!strcmp(optarg, "auto")) surface = -1;
        else if (!strcmp(optarg, "fused")) surface = 0;
        else if (!strcmp(optarg, "alpha")) surface = 1;
        else { fprintf(stderr, "morsegs vdb: --surface '%s': expected auto, fused or alpha\n", optarg); return 2; }
        break;
      case 'I': case 'V':
        if (!parse_double(optarg, &v) || v < (c == 'V') || v > 1e6 || v != floor(v)) {
          fprintf(stderr, "morsegs vdb: --%s '%s' must be an integer%s\n", c == 'V' ? "views" : "iteration", optarg,
                  c == 'V' ? " in [1, 1e6]" : " >= 0");
          return 2;
        }
        if (c == 'V') fo.views = (int)v; else fo.iteration = (int)v;
        break;
      case 1002:
        if (!parse_double(optarg, &v) || v < 8 || v > 16384 || v != floor(v)) {
          fprintf(stderr, "morsegs vdb: --view-size '%s' must be an integer in [8, 16384]\n", optarg);
          return 2;
        }
        fo.view_size = (int)v;
        break;
      case 'Z':
        if (!strcmp(optarg, "median")) fo.depth = MGS_DEPTH_MEDIAN;
        else if (!strcmp(optarg, "expected")) fo.depth = MGS_DEPTH_EXPECTED;
        else { fprintf(stderr, "morsegs vdb: --depth '%s': expected median or expected\n", optarg); return 2; }
        break;
      case 'x': case 'T': case 'X': case 'S': case 'W': {
        double *dst = c == 'x' ? &fo.voxel_fp : c == 'T' ? &fo.trunc_fp : c == 'X' ? &fo.voxel_size : c == 'S' ? &fo.truncation : NULL;
        if (!parse_double(optarg, &v) || !(v > 0) || v > 1e9) {
          fprintf(stderr, "morsegs vdb: '%s' must be a positive number\n", optarg);
          return 2;
        }
        if (dst) *dst = v; else fo.min_weight = (float)v;
        break;
      }
      case 'K':
        if (!parse_double(optarg, &v) || !(v >= 0) || v > 1e9) {
          fprintf(stderr, "morsegs vdb: --trunc-thin '%s' must be a number >= 0\n", optarg);
          return 2;
        }
        fo.thin_fp = v;
        break;
      case 'g': sugar = 1; break;
      case 'l': case 'p': case 'q': case 'u':
        if (!parse_double(optarg, &v) || v < 0 || (c == 'l' && !(v > 0 && v < 1)) || (c == 'u' && v >= 1) ||
            (c != 'l' && c != 'u' && (v > 1e9 || v != floor(v)))) {
          fprintf(stderr, "morsegs vdb: '%s': %s\n", optarg,
                  c == 'l' ? "--sugar-level must be in (0, 1)" : c == 'u' ? "--sugar-trim must be in [0, 1)"
                                                              : "--sugar-points/--sugar-triangles need an integer >= 0");
          return 2;
        }
        if (c == 'l') so.level = v;
        else if (c == 'p') so.points_per_view = (int)v;
        else if (c == 'q') so.max_triangles = (size_t)v;
        else so.trim_quantile = v;
        break;
      case 'H': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (sugar) {
    if (optind != argc - 1 || out || !mgs_is_dir(argv[optind])) {
      fprintf(stderr, "morsegs vdb: --sugar-mesh takes one RUN folder and writes RUN/mesh/sugar.{ply,vdb} (no -o)\n");
      return 2;
    }
    return mgs_cmd_vdb_sugar(argv[optind], fo.iteration, &so, ap.resolution, force);
  }
  if (from_alpha && (from_depth || no_alpha)) {
    fprintf(stderr, "morsegs vdb: --from-alpha excludes --from-depth and --no-alpha\n");
    return 2;
  }
  if (optind != argc - 1 || !out) {
    fprintf(stderr, "morsegs vdb: %s\n", !out ? "missing -o OUT.vdb" : "expected exactly one SCENE.ply or RUN folder");
    usage(stderr);
    return 2;
  }
  const char *in_arg = argv[optind];
  fo.half_width = sp.half_width;
  const int fuse = !from_alpha && (from_depth || mgs_is_dir(in_arg));
  if (surface != -1 && (!fuse || no_alpha)) {
    fprintf(stderr, "morsegs vdb: --surface chooses between the fused and the alpha-field's surface: it needs both "
                    "(a run folder or --from-depth, without --no-alpha or --from-alpha)\n");
    return 2;
  }
  if (fuse && !no_alpha && surface == -1) fo.keep_points = MGS_SURFACE_POINTS;
  if (mesh_out) {
    const char *ext = strrchr(mesh_out, '.');
    if (!ext || (strcmp(ext, ".ply") && strcmp(ext, ".obj"))) {
      fprintf(stderr, "morsegs vdb: --mesh '%s' must end in .ply or .obj\n", mesh_out);
      return 2;
    }
  }
  mgs_error err = {0};
  if (!force && mgs_path_exists(out)) {
    mgs_error_set(&err, MGS_ERR_EXISTS, "%s exists; use --force to overwrite it", out);
    return mgs_cli_fail("vdb", &err);
  }
  if (!force && mesh_out && mgs_path_exists(mesh_out)) {
    mgs_error_set(&err, MGS_ERR_EXISTS, "%s exists; use --force to overwrite it", mesh_out);
    return mgs_cli_fail("vdb", &err);
  }

  mgs_gaussians *g = NULL;
  mgs_vdb_grid *alpha = NULL, *sdf = NULL, *density = NULL, *fsdf = NULL, *tsdf = NULL, *weight = NULL;
  mgs_mesh *mesh = NULL, *amesh = NULL;
  int alpha_first = surface == 1;
  mgs_vdb_build_info info;
  memset(&info, 0, sizeof info);
  mgs_fusion_report rep;
  memset(&rep, 0, sizeof rep);
  int rc = 1;
  const double t0 = mgs_now();
  char *in = mgs_fusion_model_path(in_arg, fo.iteration, &err);
  if (!in) goto done;
  if (fuse) {
    if (mgs_fuse_path(in_arg, &fo, &fsdf, &tsdf, &weight, &rep, &err) != MGS_OK) { name_input(&err, in_arg); goto done; }
    mgs_info("depth fusion: %zu %sviews (%zu masked by their image's alpha), %s depth, footprint %.4g, voxel %.4g, "
             "truncation %.4g (%.3g footprints), %zu blocks, %zu voxels observed, sdf band %zu voxels, %.2f s",
             rep.views, rep.virtual_views ? "virtual " : "", rep.image_masks, rep.depth == MGS_DEPTH_MEDIAN ? "median" : "expected",
             rep.footprint, rep.voxel_size, rep.truncation, rep.truncation / rep.footprint, rep.blocks, rep.observed,
             rep.band_voxels, rep.seconds);
    if ((mesh_out || fo.keep_points) && mgs_vdb_extract_mesh(fsdf, 0.0, adaptivity, &mesh, &err) != MGS_OK) {
      name_input(&err, in_arg);
      goto done;
    }
    if (no_alpha) goto write;
  }
  if (mgs_ply_read_gaussians_local(in, NULL, &g, &err) != MGS_OK) goto done; /* far models: a local frame, g->origin */
  if (mgs_vdb_check_gaussians(g, in, &err) != MGS_OK) goto done;
  if (mgs_vdb_alpha_field(g, &ap, &alpha, &info, &err) != MGS_OK) { name_input(&err, in); goto done; }
  mgs_info("alpha field: %zu Gaussians, voxel size %g, %zu active voxels (%.3g%% of the %.3g dense), %.2f s",
           g->n, info.voxel_size, info.active_voxels, info.dense_voxels > 0 ? 100.0 * info.active_voxels / info.dense_voxels : 0.0,
           info.dense_voxels, info.seconds);
  const double t1 = mgs_now();
  if (mgs_vdb_sdf_from_alpha(alpha, &sp, &sdf, &err) != MGS_OK) { name_input(&err, in); goto done; }
  mgs_info("sdf: %zu active voxels (band +-%d voxels), %.2f s", mgs_vdb_grid_active_voxel_count(sdf), sp.half_width,
           mgs_now() - t1);
  if (mgs_vdb_grid_active_voxel_count(sdf) == 0)
    mgs_warn("%s: no Gaussian region reaches tau = %g; the sdf grid is empty", in, sp.tau);
  if (mgs_vdb_density_from_alpha(alpha, &density, &err) != MGS_OK) goto done;
  for (int k = 0; k < 2; k++) mgs_vdb_grid_translate(k ? sdf : density, g->origin); /* world coordinates */
  /* The mesh first, so a failure (e.g. no surface) leaves no output at all. */
  if (!fuse && mesh_out && mgs_vdb_extract_mesh(sdf, 0.0, adaptivity, &mesh, &err) != MGS_OK) { name_input(&err, in); goto done; }
  if (fuse && ((mesh_out && surface == 1) || fo.keep_points) && mgs_vdb_grid_active_voxel_count(sdf) &&
      mgs_vdb_extract_mesh(sdf, 0.0, adaptivity, &amesh, &err) != MGS_OK) {
    name_input(&err, in);
    goto done;
  }
  if (fo.keep_points) { /* --surface auto: the one closer to the renders (measure/mgs_surface_choice.h) */
    mgs_surface_agreement af, aa;
    const int pick = mgs_surface_choose(rep.points, rep.n_points, mesh, amesh, MGS_SURFACE_CAP_FP * rep.footprint, &af, &aa, &err);
    if (pick < 0) { name_input(&err, in_arg); goto done; }
    alpha_first = pick;
    mgs_info("surface choice: fused %.4g (to it %.4g, from it %.4g), alpha-field %.4g (%.4g, %.4g) over %zu rendered "
             "points -> %s", af.score, af.to_surface, af.from_surface, aa.score, aa.to_surface, aa.from_surface,
             rep.n_points, pick ? "alpha-field" : "fused");
  }
  if (alpha_first && mesh_out) { /* --mesh writes the surface that is sdf */
    mgs_mesh_destroy(mesh);
    mesh = amesh;
    amesh = NULL;
  } else if (!mesh_out) {
    mgs_mesh_destroy(mesh);
    mesh = NULL;
  }
  mgs_vdb_grid_destroy(alpha);
  alpha = NULL;
write:
  {
    mgs_vdb_file_meta meta;
    mgs_vdb_file_meta_default(&meta);
    meta.tau = fuse ? NAN : sp.tau;
    meta.voxel_size = fuse ? rep.voxel_size : info.voxel_size;
    snprintf(meta.source, sizeof meta.source, "%s", fuse ? in_arg : in);
    const mgs_vdb_grid *grids[5];
    size_t ng = 0;
    if (fuse && alpha_first && sdf) { /* first: the level set persistence and viewers pick */
      mgs_vdb_grid_set_name(fsdf, "sdf_fused");
      grids[ng++] = sdf;
      grids[ng++] = fsdf;
      grids[ng++] = tsdf;
      grids[ng++] = weight;
      grids[ng++] = density;
    } else {
      if (fuse) {
        grids[ng++] = fsdf;
        grids[ng++] = tsdf;
        grids[ng++] = weight;
        if (sdf) mgs_vdb_grid_set_name(sdf, "sdf_alpha");
      }
      if (density) grids[ng++] = density;
      if (sdf) grids[ng++] = sdf;
    }
    if (mgs_vdb_write(out, grids, ng, NULL, 0, &meta, &err) != MGS_OK) goto done;
  }
  if (mesh) {
    if (mgs_mesh_write(mesh_out, mesh, &err) != MGS_OK) goto done;
    mgs_info("mesh: %zu vertices, %zu triangles -> %s", mesh->nv, mesh->nt, mesh_out);
  }
  if (fuse)
    printf("%s: %s (depth fusion of %zu %sviews, %s depth) %zu active voxels, voxel size %g, truncation %g (%.3g pixel "
           "footprints)%s, %.2f s, peak RSS %.1f MiB\n", out, alpha_first && sdf ? "sdf_fused" : "sdf", rep.views,
           rep.virtual_views ? "virtual " : "", rep.depth == MGS_DEPTH_MEDIAN ? "median" : "expected", rep.band_voxels,
           rep.voxel_size, rep.truncation, rep.truncation / rep.footprint,
           !sdf ? "" : alpha_first ? "; alpha-field: sdf (it agrees better with the renders), density" : "; alpha-field: density, sdf_alpha",
           mgs_now() - t0, mgs_peak_rss() / 1048576.0);
  else
    printf("%s: density %zu + sdf %zu active voxels, voxel size %g, tau %g, %.2f s, peak RSS %.1f MiB\n", out,
           mgs_vdb_grid_active_voxel_count(density), mgs_vdb_grid_active_voxel_count(sdf), info.voxel_size, sp.tau,
           mgs_now() - t0, mgs_peak_rss() / 1048576.0);
  rc = 0;
done:
  free(rep.points);
  mgs_mesh_destroy(mesh);
  mgs_mesh_destroy(amesh);
  mgs_vdb_grid_destroy(alpha);
  mgs_vdb_grid_destroy(sdf);
  mgs_vdb_grid_destroy(density);
  mgs_vdb_grid_destroy(fsdf);
  mgs_vdb_grid_destroy(tsdf);
  mgs_vdb_grid_destroy(weight);
  mgs_gaussians_destroy(g);
  free(in);
  return rc ? mgs_cli_fail("vdb", &err) : 0;
}
