#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>

#include "silpose/cli/commands.h"
#include "silpose/database/database_builder.h"
#include "silpose/match/view_matcher.h"
#include "silpose/util/error.h"
#include "silpose/util/output_file.h"
#include "silpose/util/progress.h"

namespace silpose::cli {
namespace {

struct BuildDbArguments {
  std::vector<std::string> models;
  std::string output;
  DatabaseBuildOptions options;
  bool force = false;
};

// Beyond these a database is refused unless --force (docs/limits.md): a bigger file is slow to
// load, and every match and track run holds it and its spectra in memory.
constexpr double kMaxFileBytes = 2e9;
constexpr double kMaxMatchMemoryBytes = 4e9;

double PhysicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_size = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && page_size > 0 ? static_cast<double>(pages) * static_cast<double>(page_size)
                                    : 0.0;
}

// Prints what the database will cost and refuses it, before building, if it is beyond the bounds.
void CheckDatabaseSize(const BuildDbArguments& arguments) {
  std::string problem;
  if (!arguments.options.Check(&problem)) ThrowError("invalid database options: ", problem);
  double mesh_bytes = 0.0;
  for (const std::string& model : arguments.models) {
    std::error_code error;
    const auto size = std::filesystem::file_size(model, error);
    if (!error) mesh_bytes += static_cast<double>(size);
  }
  const DatabaseParameters& parameters = arguments.options.parameters;
  const int threads = arguments.options.num_threads > 0
                          ? arguments.options.num_threads
                          : static_cast<int>(std::max(1L, ::sysconf(_SC_NPROCESSORS_ONLN)));
  const DatabaseSizeEstimate estimate =
      EstimateDatabaseSize(parameters, static_cast<int>(arguments.models.size()), mesh_bytes,
                           threads, arguments.options.keep_signatures);
  auto bytes = [](double value) { return FormatBytes(static_cast<uintmax_t>(value)); };
  std::printf(
      "estimate: %zu models x %d views x %d shells, signatures of %d: a file of about %s, about "
      "%s of memory to build, about %s for match and track\n",
      arguments.models.size(), parameters.view_sphere.num_views, parameters.num_shells(),
      parameters.signature.length, bytes(estimate.file_bytes).c_str(),
      bytes(estimate.build_memory_bytes).c_str(), bytes(estimate.match_memory_bytes).c_str());
  std::fflush(stdout);
  if (!arguments.force &&
      (estimate.file_bytes > kMaxFileBytes || estimate.match_memory_bytes > kMaxMatchMemoryBytes)) {
    ThrowError(
        "the database would be about ", bytes(estimate.file_bytes), " (matching needs about ",
        bytes(estimate.match_memory_bytes), " of memory), beyond the limits of ",
        bytes(kMaxFileBytes), " and ", bytes(kMaxMatchMemoryBytes), ": use fewer --views (",
        parameters.view_sphere.num_views, "), a shorter --signature-length (",
        parameters.signature.length, ") or fewer --distances, or pass --force to build it anyway");
  }
  const double memory = PhysicalMemoryBytes();
  if (memory > 0.0 && estimate.build_memory_bytes > memory) {
    ThrowError("the database needs about ", bytes(estimate.build_memory_bytes),
               " of memory to build but this machine has ", bytes(memory),
               ": use fewer --views, a shorter --signature-length or fewer --distances");
  }
}

void PrintDatabaseSummary(const ViewDatabase& database) {
  std::printf("%d views x %d distance shells (", database.num_views(), database.num_shells());
  for (int s = 0; s < database.num_shells(); ++s) {
    std::printf("%s%g", s > 0 ? ", " : "",
                database.parameters.distances_in_radii[static_cast<size_t>(s)]);
  }
  std::printf(" radii)\n");
  std::printf("%-24s %9s %10s %7s %8s %7s %7s\n", "model", "triangles", "radius", "usable",
              "circular", "holes", "border");
  for (const ModelViews& model : database.models) {
    int usable = 0, circular = 0, holes = 0, border = 0;
    for (const ViewRecord& view : model.views) {
      usable += view.status == SignatureStatus::kOk;
      circular += (view.flags & kSilhouetteNearlyCircular) != 0;
      holes += (view.flags & kSilhouetteHasHoles) != 0;
      border += (view.flags & kSilhouetteTouchesBorder) != 0;
    }
    std::printf("%-24s %9u %10.4g %7d %8d %7d %7d\n", model.name.c_str(), model.num_triangles,
                model.radius, usable, circular, holes, border);
    if (usable < static_cast<int>(model.views.size())) {
      std::fprintf(stderr,
                   "silpose build-db: warning: %s: %d view renderings (over all shells) had no "
                   "describable silhouette and will never match\n",
                   model.name.c_str(), static_cast<int>(model.views.size()) - usable);
    }
  }
  // Symmetries (docs/symmetry.md): poses of a model with rotations are reported in canonical form.
  std::printf("symmetries (model frame):\n");
  for (const ModelViews& model : database.models)
    std::printf("  %-22s %s\n", model.name.c_str(), model.symmetry.Describe().c_str());
}

void RunBuildDb(const BuildDbArguments& arguments) {
  // The output first: a path that cannot be written, or that another silpose process is writing,
  // is refused before minutes of rendering.
  CheckReplaceable(arguments.output);
  CheckOutputPath(arguments.output, "-o");
  const OutputLock lock(arguments.output);
  CheckDatabaseSize(arguments);
  std::vector<std::filesystem::path> paths(arguments.models.begin(), arguments.models.end());
  DatabaseBuildOptions options = arguments.options;
  options.show_progress = true;
  const auto start = std::chrono::steady_clock::now();
  ViewDatabase database = BuildViewDatabase(paths, options);
  // The views' spectra go into the file: opening it then transforms nothing (docs/PERFORMANCE.md).
  StoreViewSpectra(&database, CorrelationOptions{}, options.num_threads);
  // Unless asked to keep them, the signatures are left out of the file: the pose derives them
  // from the spectra (docs/database-format.md).
  if (!options.keep_signatures) database.DropSignatures();
  database.Write(arguments.output);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  PrintDatabaseSummary(database);
  std::error_code error;
  const auto size = std::filesystem::file_size(arguments.output, error);
  std::printf("wrote %s: %zu models x %d views, signatures of %d (%s), %s, in %.1f s\n",
              arguments.output.c_str(), database.models.size(), database.num_views(),
              database.signature_length(),
              options.keep_signatures ? "stored" : "derived from the stored spectra",
              error ? "?" : FormatBytes(size).c_str(), seconds);
}

}  // namespace

void AddBuildDbCommand(CLI::App& app) {
  auto arguments = std::make_shared<BuildDbArguments>();
  CLI::App* command = app.add_subcommand(
      "build-db",
      "Render each mesh from near-uniform viewpoints on a sphere, describe each silhouette by its "
      "polar signature and store the signatures' spectra (the signatures themselves with "
      "--full-signatures), the views' neighbour graph and K-means bins in a database file.");
  DatabaseParameters& parameters = arguments->options.parameters;
  command
      ->add_option("models", arguments->models,
                   "Mesh files (OBJ, PLY, STL, OFF, glTF, ...); model names are file stems")
      ->required();
  command->add_option("-o,--output", arguments->output, "Database file to write")->required();
  command
      ->add_option("--views", parameters.view_sphere.num_views,
                   "Viewpoints on the sphere (paper: 1000)")
      ->capture_default_str();
  command
      ->add_option("--signature-length", parameters.signature.length,
                   "Radii per signature, M (even; paper: 1000)")
      ->capture_default_str();
  command
      ->add_option("--resolution", parameters.render.resolution_px,
                   "Rendered image width and height, pixels")
      ->capture_default_str();
  command
      ->add_option("--distances", parameters.distances_in_radii,
                   "Camera distances of the distance shells, object radii, increasing (one "
                   "rendering per view and shell; '3' is the paper's single shell)")
      ->delimiter(',')
      ->capture_default_str();
  command
      ->add_option("--fill", parameters.render.fill_fraction,
                   "Share of the image width the object's bounding sphere fills")
      ->capture_default_str();
  command
      ->add_option("--bins", parameters.view_sphere.num_bins,
                   "K-means bins of the views, for KLD-sampling (paper: 10)")
      ->capture_default_str();
  command
      ->add_option("--neighbour-radius", parameters.view_sphere.neighbour_radius_factor,
                   "Views closer than this many typical spacings are neighbours")
      ->capture_default_str();
  command->add_option("--threads", arguments->options.num_threads, "Worker threads (0 = all cores)")
      ->capture_default_str();
  command->add_flag("--full-signatures", arguments->options.keep_signatures,
                    "Also store every view's raw signature (about 4 kB a view and shell more), "
                    "not only its smoothed spectrum: needed only to match with another "
                    "signature smoothing than the default");
  command->add_flag("--force", arguments->force,
                    "Build even if the estimated file is larger than 2 GB or match and track would "
                    "need more than 4 GB of memory (never beyond the machine's memory)");
  command->callback([arguments] { RunBuildDb(*arguments); });
}

}  // namespace silpose::cli
