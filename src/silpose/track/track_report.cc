#include "silpose/track/track_report.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace silpose {
namespace {

const Rgb kTruthGrey{150, 150, 150};
const Rgb kWrongRed{214, 39, 40};

// Unit circle (the sphere's outline) as a thin grey line.
PlotSeries Outline() {
  PlotSeries outline;
  outline.marker = Marker::kNone;
  outline.colour = Rgb{200, 200, 200};
  outline.line_width_px = 1.0;
  for (int i = 0; i <= 180; ++i) {
    const double angle = 2.0 * M_PI * i / 180.0;
    outline.x.push_back(std::cos(angle));
    outline.y.push_back(std::sin(angle));
  }
  return outline;
}

// Hemisphere `side` (+1: z >= 0, seen from +z; -1: z < 0, seen from -z with x mirrored).
bool OnSide(const Eigen::Vector3d& d, int side) { return side > 0 ? d.z() >= 0.0 : d.z() < 0.0; }
double PlotX(const Eigen::Vector3d& d, int side) { return side > 0 ? d.x() : -d.x(); }

}  // namespace

TruthFrame MakeTruthFrame(const ViewDatabase& database, const std::string& object,
                          const Eigen::Vector3d& view_dir_in_object,
                          const Rigid3& camera_from_object) {
  TruthFrame truth;
  truth.object = object;
  truth.view_dir_in_object = view_dir_in_object;
  truth.camera_from_object = camera_from_object;
  const int model = database.FindModel(object);
  if (model >= 0) {
    const ModelViews& views = database.models[static_cast<size_t>(model)];
    truth.object_centre = Eigen::Vector3d(views.centre[0], views.centre[1], views.centre[2]);
  }
  return truth;
}

TrackReport::TrackReport(std::vector<std::string> object_names)
    : object_names_(std::move(object_names)) {}

TrackReport::TrackReport(const ViewDatabase& database) {
  for (const ModelViews& model : database.models) {
    object_names_.push_back(model.name);
    if (model.symmetry.HasRotations()) symmetries_[model.name] = SymmetryTransforms(model.symmetry);
  }
}

void TrackReport::Add(const FrameResult& result, const std::optional<TruthFrame>& truth) {
  frames_.push_back({result, truth});
  truth_frames_ += truth.has_value();
}

TrackAccuracy TrackReport::Accuracy(int skip_frames) const {
  TrackAccuracy accuracy;
  std::vector<double> view_errors, rotation_errors, translation_errors;
  std::vector<double> view_errors_symmetric, rotation_errors_symmetric;
  for (size_t i = static_cast<size_t>(std::max(skip_frames, 0)); i < frames_.size(); ++i) {
    const Entry& entry = frames_[i];
    if (!entry.truth) continue;
    ++accuracy.frames;
    const bool right = entry.result.object >= 0 && entry.result.object_name == entry.truth->object;
    accuracy.right_object += right;
    std::span<const Rigid3> symmetries;
    if (right) {
      const auto found = symmetries_.find(entry.truth->object);
      if (found != symmetries_.end()) symmetries = found->second;
    }
    if (entry.result.view_dir_in_object) {
      view_errors.push_back(
          ViewDirectionError(*entry.result.view_dir_in_object, entry.truth->view_dir_in_object));
      view_errors_symmetric.push_back(ViewErrorModuloSymmetry(
          *entry.result.view_dir_in_object, entry.truth->view_dir_in_object, symmetries));
    }
    if (right && entry.result.camera_from_object) {
      const Rigid3& estimated = *entry.result.camera_from_object;
      const Rigid3& truth = entry.truth->camera_from_object;
      rotation_errors.push_back(RotationErrorDeg(estimated.rotation, truth.rotation));
      rotation_errors_symmetric.push_back(
          RotationErrorModuloSymmetryDeg(estimated.rotation, truth.rotation, symmetries));
      const double distance =
          (truth.rotation * entry.truth->object_centre + truth.translation).norm();
      translation_errors.push_back((estimated.translation - truth.translation).norm() / distance);
    }
  }
  accuracy.view_error = Summarize(view_errors);
  accuracy.rotation_deg = Summarize(rotation_errors);
  accuracy.translation_relative = Summarize(translation_errors);
  accuracy.view_error_symmetric = Summarize(view_errors_symmetric);
  accuracy.rotation_deg_symmetric = Summarize(rotation_errors_symmetric);
  accuracy.view_values_symmetric = std::move(view_errors_symmetric);
  accuracy.rotation_values_deg_symmetric = std::move(rotation_errors_symmetric);
  accuracy.view_values = std::move(view_errors);
  accuracy.rotation_values_deg = std::move(rotation_errors);
  accuracy.translation_values_relative = std::move(translation_errors);
  return accuracy;
}

std::array<int, 6> TrackReport::StateCounts() const {
  std::array<int, 6> counts{};
  for (const Entry& entry : frames_) ++counts[static_cast<size_t>(entry.result.state)];
  return counts;
}

TrackReport::StageTimes TrackReport::MeanStageTimes() const {
  const auto mean = [this](double FrameResult::*field) {
    double sum = 0.0;
    int count = 0;
    for (const Entry& entry : frames_) {
      const double ms = entry.result.*field;
      if (std::isfinite(ms)) {
        sum += ms;
        ++count;
      }
    }
    return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
  };
  StageTimes times;
  times.segment_ms = mean(&FrameResult::time_segment_ms);
  times.describe_ms = mean(&FrameResult::time_describe_ms);
  times.match_ms = mean(&FrameResult::time_match_ms);
  times.pose_ms = mean(&FrameResult::time_pose_ms);
  times.refine_ms = mean(&FrameResult::time_refine_ms);
  return times;
}

std::vector<TrackReport::ObjectChange> TrackReport::ObjectChanges(int stable_frames) const {
  std::vector<ObjectChange> changes;
  std::vector<size_t> starts;
  for (size_t i = 1; i < frames_.size(); ++i) {
    if (frames_[i].truth && frames_[i - 1].truth &&
        frames_[i].truth->object != frames_[i - 1].truth->object) {
      starts.push_back(i);
    }
  }
  for (size_t k = 0; k < starts.size(); ++k) {
    const size_t begin = starts[k];
    const size_t end = k + 1 < starts.size() ? starts[k + 1] : frames_.size();
    ObjectChange change;
    change.frame = frames_[begin].result.frame;
    size_t run = 0;
    for (size_t i = begin; i < end; ++i) {
      const bool right = frames_[i].truth && frames_[i].result.object >= 0 &&
                         frames_[i].result.object_name == frames_[i].truth->object;
      run = right ? run + 1 : 0;
      if (run == static_cast<size_t>(std::max(stable_frames, 1))) {
        change.delay = static_cast<int>(i + 1 - run - begin);
        break;
      }
    }
    changes.push_back(change);
  }
  return changes;
}

Figure TrackReport::TrajectoryFigure(const std::string& title) const {
  Figure figure;
  figure.width_px = 1000;
  figure.height_px = 520;
  std::vector<int> order;  // objects in order of first appearance among the estimates
  for (const Entry& entry : frames_) {
    const int o = entry.result.object;
    if (o >= 0 && static_cast<size_t>(o) < object_names_.size() &&
        std::find(order.begin(), order.end(), o) == order.end()) {
      order.push_back(o);
    }
  }
  for (int side : {+1, -1}) {
    PlotPanel panel;
    panel.title = side > 0 && !title.empty() ? title + ": " : std::string();
    panel.title += side > 0 ? "view sphere from +z (z >= 0)" : "view sphere from -z (z < 0)";
    panel.x_axis.label = side > 0 ? "x" : "-x";
    panel.y_axis.label = std::string("y");  // (a literal trips GCC 12's -Wrestrict)
    panel.x_axis.min = panel.y_axis.min = -1.1;
    panel.x_axis.max = panel.y_axis.max = 1.1;
    panel.equal_aspect = true;
    panel.legend = LegendPosition::kBest;
    panel.series.push_back(Outline());
    // The truth: a grey line, broken where it changes hemisphere.
    bool labelled = false;
    PlotSeries run;
    auto flush = [&] {
      if (run.x.size() >= 1) {
        if (!labelled) run.label = "truth";
        labelled = true;
        panel.series.push_back(run);
      }
      run = PlotSeries();
      run.marker = Marker::kNone;
      run.colour = kTruthGrey;
      run.line_width_px = 2.0;
    };
    flush();
    for (const Entry& entry : frames_) {
      if (!entry.truth || !OnSide(entry.truth->view_dir_in_object, side)) {
        flush();
        continue;
      }
      run.x.push_back(PlotX(entry.truth->view_dir_in_object, side));
      run.y.push_back(entry.truth->view_dir_in_object.y());
    }
    flush();
    // The estimates: markers, one series per object, coloured in order of first appearance
    // (palette grey is the truth's).
    for (size_t k = 0; k < order.size(); ++k) {
      const size_t o = static_cast<size_t>(order[k]);
      PlotSeries estimates;
      estimates.label = object_names_[o];
      estimates.line = false;
      estimates.marker = Marker::kCircle;
      estimates.marker_radius_px = 2.5;
      const int colour = static_cast<int>(k) % 9;
      estimates.colour = PaletteColour(colour >= 7 ? colour + 1 : colour);
      for (const Entry& entry : frames_) {
        if (entry.result.object != static_cast<int>(o) || !entry.result.view_dir_in_object)
          continue;
        const Eigen::Vector3d& d = *entry.result.view_dir_in_object;
        if (!OnSide(d, side)) continue;
        estimates.x.push_back(PlotX(d, side));
        estimates.y.push_back(d.y());
      }
      if (!estimates.x.empty()) panel.series.push_back(estimates);
    }
    figure.panels.push_back(std::move(panel));
  }
  return figure;
}

Figure TrackReport::ErrorFigure(const std::string& title) const {
  Figure figure;
  figure.width_px = 1100;
  figure.height_px = 400;
  PlotPanel view_panel;
  view_panel.title = title.empty() ? "pose error (view direction)" : title + ": pose error";
  view_panel.x_axis.label = "frame";
  view_panel.y_axis.label = "|d_est - d_true| (unit sphere)";
  view_panel.y_axis.min = 0.0;
  PlotPanel rotation_panel;
  rotation_panel.title = "rotation error (6-DOF pose)";
  rotation_panel.x_axis.label = "frame";
  rotation_panel.y_axis.label = "degrees";
  rotation_panel.y_axis.min = 0.0;

  PlotSeries view_right, view_wrong, rotation;
  view_right.label = "right object";
  view_right.line = false;
  view_right.marker_radius_px = 2.0;
  view_right.colour = PaletteColour(0);
  view_wrong.label = "wrong object";
  view_wrong.line = false;
  view_wrong.marker = Marker::kCross;
  view_wrong.colour = kWrongRed;
  rotation.line = false;
  rotation.marker_radius_px = 2.0;
  rotation.colour = PaletteColour(0);
  for (const Entry& entry : frames_) {
    if (!entry.truth || !entry.result.view_dir_in_object) continue;
    const double x = entry.result.frame;
    const bool right = entry.result.object_name == entry.truth->object;
    PlotSeries& target = right ? view_right : view_wrong;
    target.x.push_back(x);
    target.y.push_back(
        ViewDirectionError(*entry.result.view_dir_in_object, entry.truth->view_dir_in_object));
    if (right && entry.result.camera_from_object) {
      rotation.x.push_back(x);
      rotation.y.push_back(RotationErrorDeg(entry.result.camera_from_object->rotation,
                                            entry.truth->camera_from_object.rotation));
    }
  }
  view_panel.series.push_back(view_right);
  if (!view_wrong.x.empty()) view_panel.series.push_back(view_wrong);
  rotation_panel.series.push_back(rotation);
  rotation_panel.legend = LegendPosition::kNone;
  figure.panels.push_back(std::move(view_panel));
  figure.panels.push_back(std::move(rotation_panel));
  return figure;
}

}  // namespace silpose
