#include "silpose/track/track_report.h"

#include <gtest/gtest.h>

#include <cmath>

#include "silpose/geometry/view_frame.h"

namespace silpose {
namespace {

FrameResult Result(int frame, int object, const std::string& name, const Eigen::Vector3d& view,
                   const std::optional<Rigid3>& pose) {
  FrameResult result;
  result.frame = frame;
  result.object = object;
  result.object_name = name;
  result.view_dir_in_object = view;
  result.camera_from_object = pose;
  return result;
}

TruthFrame Truth(const std::string& name, const Eigen::Vector3d& view, const Rigid3& pose) {
  TruthFrame truth;
  truth.object = name;
  truth.view_dir_in_object = view;
  truth.camera_from_object = pose;
  return truth;
}

TEST(TrackReport, AccuracyCountsObjectsAndErrors) {
  TrackReport report({"cow", "hand"});
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX();
  const Rigid3 truth_pose = CameraFromObjectAtView(z, 0.0, 10.0, Eigen::Vector3d::Zero());
  Rigid3 shifted = truth_pose;
  shifted.translation.z() += 0.5;  // 5 % of the distance
  // Frame 0: wrong object (skipped below); 1: right, exact; 2: right, shifted; 3: wrong object;
  // 4: no estimate at all.
  report.Add(Result(0, 1, "hand", x, truth_pose), Truth("cow", z, truth_pose));
  report.Add(Result(1, 0, "cow", z, truth_pose), Truth("cow", z, truth_pose));
  report.Add(Result(2, 0, "cow", z, shifted), Truth("cow", z, truth_pose));
  report.Add(Result(3, 1, "hand", x, std::nullopt), Truth("cow", z, truth_pose));
  FrameResult none;
  none.frame = 4;
  report.Add(none, Truth("cow", z, truth_pose));
  EXPECT_TRUE(report.has_truth());

  const TrackAccuracy all = report.Accuracy();
  EXPECT_EQ(all.frames, 5);
  EXPECT_EQ(all.right_object, 2);
  EXPECT_NEAR(all.RightObjectPercent(), 40.0, 1e-12);
  EXPECT_EQ(all.view_error.count, 4);  // frame 4 has no view
  EXPECT_NEAR(all.view_error.max, std::sqrt(2.0), 1e-12);
  EXPECT_EQ(all.rotation_deg.count, 2);
  EXPECT_NEAR(all.rotation_deg.max, 0.0, 1e-9);
  EXPECT_NEAR(all.translation_relative.max, 0.05, 1e-12);

  const TrackAccuracy skipped = report.Accuracy(1);
  EXPECT_EQ(skipped.frames, 4);
  EXPECT_EQ(skipped.right_object, 2);
}

TEST(TrackReport, ErrorsModuloSymmetryForgiveOnlyTheSymmetryOfTheTrueObject) {
  // A database of two models by name: a bottle symmetric about z, and a box without rotations.
  ViewDatabase database;
  database.models.resize(2);
  database.models[0].name = "bottle";
  database.models[0].symmetry.continuous.push_back({.axis = Eigen::Vector3d::UnitZ()});
  database.models[1].name = "box";
  TrackReport report(database);
  const Eigen::Vector3d view = Eigen::Vector3d(1.0, 0.0, 1.0).normalized();
  const Rigid3 truth = CameraFromObjectAtView(view, 20.0, 10.0, Eigen::Vector3d::Zero());
  // The estimate is the truth turned by 90 degrees about the bottle's axis.
  Rigid3 turn;
  turn.rotation = Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Rigid3 turned = truth * turn;
  const Eigen::Vector3d turned_view = turn.rotation.transpose() * view;
  report.Add(Result(0, 0, "bottle", turned_view, turned), Truth("bottle", view, truth));
  // The same mistake on the box, and a wrong object (the bottle's view for the box).
  report.Add(Result(1, 1, "box", turned_view, turned), Truth("box", view, truth));
  report.Add(Result(2, 0, "bottle", turned_view, turned), Truth("box", view, truth));
  const TrackAccuracy accuracy = report.Accuracy();
  ASSERT_EQ(accuracy.rotation_values_deg.size(), 2u);
  EXPECT_NEAR(accuracy.rotation_values_deg[0], 90.0, 1e-6);
  EXPECT_LT(accuracy.rotation_values_deg_symmetric[0], 0.6);  // sampled symmetry
  EXPECT_NEAR(accuracy.rotation_values_deg_symmetric[1], 90.0, 1e-6);
  ASSERT_EQ(accuracy.view_values_symmetric.size(), 3u);
  EXPECT_GT(accuracy.view_values[0], 0.9);
  EXPECT_LT(accuracy.view_values_symmetric[0], 0.01);
  EXPECT_NEAR(accuracy.view_values_symmetric[1], accuracy.view_values[1], 1e-12);
  EXPECT_NEAR(accuracy.view_values_symmetric[2], accuracy.view_values[2], 1e-12);
  // Without a database the errors are the plain ones.
  TrackReport plain({"bottle", "box"});
  plain.Add(Result(0, 0, "bottle", turned_view, turned), Truth("bottle", view, truth));
  EXPECT_NEAR(plain.Accuracy().rotation_values_deg_symmetric[0], 90.0, 1e-6);
}

TEST(TrackReport, MeanStageTimesSkipStagesThatDidNotRun) {
  TrackReport report({"cow"});
  FrameResult first = Result(0, 0, "cow", Eigen::Vector3d::UnitZ(), std::nullopt);
  first.time_segment_ms = 1.0;
  first.time_describe_ms = 0.5;
  first.time_match_ms = 2.0;
  first.time_refine_ms = 3.0;
  FrameResult second = Result(1, 0, "cow", Eigen::Vector3d::UnitZ(), std::nullopt);
  second.time_segment_ms = 3.0;  // no silhouette: nothing after segmentation ran
  report.Add(first);
  report.Add(second);
  const TrackReport::StageTimes times = report.MeanStageTimes();
  EXPECT_DOUBLE_EQ(times.segment_ms, 2.0);
  EXPECT_DOUBLE_EQ(times.describe_ms, 0.5);
  EXPECT_DOUBLE_EQ(times.match_ms, 2.0);
  EXPECT_TRUE(std::isnan(times.pose_ms));
  EXPECT_DOUBLE_EQ(times.refine_ms, 3.0);
}

TEST(TrackReport, ObjectChangesAndTheirDelays) {
  TrackReport report({"cow", "hand"});
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Rigid3 pose = CameraFromObjectAtView(z, 0.0, 10.0, Eigen::Vector3d::Zero());
  // Truth: cow 0-9, hand 10-29, cow 30-34. Estimate: cow until 12, then hand (flickering to cow at
  // 15), cow never again.
  for (int f = 0; f < 35; ++f) {
    const std::string truth = f < 10 || f >= 30 ? "cow" : "hand";
    const bool cow = f < 13 || f == 15;
    report.Add(Result(f, cow ? 0 : 1, cow ? "cow" : "hand", z, pose), Truth(truth, z, pose));
  }
  const std::vector<TrackReport::ObjectChange> changes = report.ObjectChanges(5);
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].frame, 10);
  EXPECT_EQ(changes[0].delay, 6);  // hand from 16 on for 5 frames (13, 14 broken by 15)
  EXPECT_EQ(changes[1].frame, 30);
  EXPECT_EQ(changes[1].delay, -1);
}

TEST(TrackReport, FiguresShowTheTrajectoryAndTheErrors) {
  TrackReport report({"cow", "hand"});
  for (int f = 0; f < 90; ++f) {
    const double angle = f * M_PI / 45.0;  // a great circle through both hemispheres
    const Eigen::Vector3d view(std::cos(angle), 0.2, std::sin(angle));
    const Eigen::Vector3d truth_view = view.normalized();
    const Rigid3 pose = CameraFromObjectAtView(truth_view, 0.0, 5.0, Eigen::Vector3d::Zero());
    const int object = f < 60 ? 0 : 1;
    report.Add(Result(f, object, object == 0 ? "cow" : "hand", truth_view, pose),
               Truth("cow", truth_view, pose));
  }
  const Figure trajectory = report.TrajectoryFigure("test");
  ASSERT_EQ(trajectory.panels.size(), 2u);
  std::string problem;
  EXPECT_TRUE(trajectory.Check(&problem)) << problem;
  // Each hemisphere: the outline, the truth (one or more runs), the estimates of both objects.
  for (const PlotPanel& panel : trajectory.panels) {
    int estimate_points = 0;
    for (const PlotSeries& series : panel.series) {
      if (series.label == "cow" || series.label == "hand")
        estimate_points += static_cast<int>(series.x.size());
    }
    EXPECT_GT(estimate_points, 30);
  }
  const Figure errors = report.ErrorFigure();
  ASSERT_EQ(errors.panels.size(), 2u);
  EXPECT_TRUE(errors.Check(&problem)) << problem;
  // Frames 60..89 name the wrong object: they are the "wrong object" series.
  ASSERT_EQ(errors.panels[0].series.size(), 2u);
  EXPECT_EQ(errors.panels[0].series[1].label, "wrong object");
  EXPECT_EQ(errors.panels[0].series[1].x.size(), 30u);
  EXPECT_EQ(errors.panels[1].series[0].x.size(), 60u);  // rotation errors: right object only
  EXPECT_FALSE(trajectory.ToSvg().empty());
}

}  // namespace
}  // namespace silpose
