#include <cmath>
#include <cstdio>
#include <memory>
#include <opencv2/core.hpp>

#include "silpose/cli/commands.h"
#include "silpose/geometry/view_frame.h"
#include "silpose/io/camera_file.h"
#include "silpose/io/mask_file.h"
#include "silpose/render/silhouette_renderer.h"
#include "silpose/shape/polar_signature.h"
#include "silpose/util/error.h"

namespace silpose::cli {
namespace {

struct RenderArguments {
  std::string model;
  std::string view = "0,0,1";
  double roll_deg = 0.0;
  std::string camera;
  std::string output;
  ViewRenderOptions render;
};

void RunRender(const RenderArguments& arguments) {
  const std::vector<double> v = ParseTriple(arguments.view, "--view");
  const Eigen::Vector3d view_dir(v[0], v[1], v[2]);
  const double norm = view_dir.norm();
  if (!(norm > 1e-12) || !std::isfinite(norm)) {
    ThrowError("--view must be a non-zero direction of finite length, got '", arguments.view, "'");
  }
  std::string problem;
  if (!arguments.render.Check(&problem)) ThrowError("invalid rendering options: ", problem);
  if (!std::isfinite(arguments.roll_deg)) ThrowError("--roll must be a finite number of degrees");
  const TriangleMesh mesh = LoadMesh(arguments.model);
  cv::Mat mask;
  if (arguments.camera.empty()) {
    RenderView(mesh, view_dir, arguments.roll_deg, arguments.render, &mask);
  } else {
    const PinholeCamera camera = ReadCameraFile(arguments.camera);
    if (!(mesh.Radius() > 0.0)) ThrowError(arguments.model, ": the mesh has no extent");
    const Rigid3 camera_from_object =
        CameraFromObjectAtView(view_dir, arguments.roll_deg,
                               arguments.render.distance_in_radii * mesh.Radius(), mesh.Centre());
    RenderSilhouette(mesh, camera, camera_from_object, &mask);
  }
  WriteMask(arguments.output, mask);
  const int pixels = cv::countNonZero(mask);
  std::printf("wrote %s: %dx%d, %d object pixels, view (%.4f, %.4f, %.4f), roll %.2f deg\n",
              arguments.output.c_str(), mask.cols, mask.rows, pixels, view_dir.normalized().x(),
              view_dir.normalized().y(), view_dir.normalized().z(), arguments.roll_deg);
  const SignatureResult silhouette = ExtractSignature(mask);
  if (silhouette.flags & kSilhouetteTouchesBorder) {
    std::fprintf(stderr,
                 "silpose render: warning: the silhouette touches the image border; increase "
                 "--distance\n");
  }
  if (pixels == 0) {
    std::fprintf(stderr, "silpose render: warning: the object is not in the image\n");
  }
}

}  // namespace

void AddRenderCommand(CLI::App& app) {
  auto arguments = std::make_shared<RenderArguments>();
  CLI::App* command = app.add_subcommand(
      "render",
      "Render a mesh's silhouette as a mask image, seen from a view direction with a camera roll "
      "(camera looking at the object centre, OpenCV camera conventions).");
  command->add_option("model", arguments->model, "Mesh file")->required();
  command
      ->add_option("--view", arguments->view,
                   "Direction from the object centre to the camera, model frame, X,Y,Z "
                   "(write --view=-1,0,0 for negative values)")
      ->capture_default_str();
  command
      ->add_option("--roll", arguments->roll_deg,
                   "Camera roll about its optical axis, degrees (image x towards image y)")
      ->capture_default_str();
  command->add_option("--camera", arguments->camera,
                      "OpenCV calibration YAML (camera_matrix, image_width, ...); default: a "
                      "square image framing the object");
  command
      ->add_option("--resolution", arguments->render.resolution_px,
                   "Image size without --camera, pixels")
      ->capture_default_str();
  command
      ->add_option("--distance", arguments->render.distance_in_radii,
                   "Camera distance from the object centre, in object radii")
      ->capture_default_str();
  command->add_option("-o,--output", arguments->output, "Mask image to write (PNG)")->required();
  command->callback([arguments] { RunRender(*arguments); });
}

}  // namespace silpose::cli
