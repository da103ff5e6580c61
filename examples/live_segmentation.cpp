// SPDX-License-Identifier: BSD-3-Clause
// A grabber-driven segmentation loop, the way a PCL application runs a live camera:
//   a pcl::Grabber (cuefusion's grabbers for recorded sequences, or an OpenNI2 camera)
//   calls back with each RGB-D frame → cuefusion::pipeline::FusionPipeline tracks, fuses and
//   segments it → every N frames the labelled map is saved as a PCD (PointXYZRGBL; open
//   it with pcl_viewer and press 'l' to colour by label). With "network" as the last
//   argument the masks come from cuefusion's own network (installed with the library).
//
// usage: live_segmentation SOURCE OUT_DIR [EVERY_N [network|MODEL.onnx]]
//   SOURCE: a sequence folder (TUM, Redwood, 7-Scenes, ScanNet layouts), an .oni
//   recording, or openni2 for the first connected camera (Ctrl-C stops a camera).

#include <cuefusion/common/data_directory.h>
#include <cuefusion/io/sequence.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/recognition/onnx_instance_segmenter.h>

#include <pcl/io/pcd_io.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace
{
std::atomic<bool> g_stop{false};
}

int
main (int argc, char** argv)
{
  if (argc < 3)
  {
    std::cerr << "usage: live_segmentation SOURCE OUT_DIR [EVERY_N [network|MODEL.onnx]]\n";
    return 2;
  }
  const std::string source = argv[1], out_dir = argv[2];
  const long every = argc > 3 ? std::max (1L, std::strtol (argv[3], nullptr, 10)) : 10;
  std::string model = argc > 4 ? argv[4] : "";
  if (model == "network")
    model = cuefusion::dataDirectory () + "/models/xyz_instances.onnx";
  std::signal (SIGINT, [] (int) { g_stop = true; });

  try
  {
    cuefusion::pipeline::FusionPipelineConfig config;
    config.mode = model.empty () ? cuefusion::pipeline::SegmentationMode::Geometry : cuefusion::pipeline::SegmentationMode::Fused;
    cuefusion::pipeline::FusionPipeline fusion (config);
    std::unique_ptr<cuefusion::recognition::InstanceSegmenter> masks;
    if (!model.empty ())
    {
      cuefusion::recognition::OnnxInstanceSegmenterConfig onnx;
      onnx.model_path = model;
      masks = std::make_unique<cuefusion::recognition::OnnxInstanceSegmenter> (onnx);
    }

    const cuefusion::io::RGBDGrabber::Ptr grabber = cuefusion::io::openSequence (source);
    std::mutex mutex;
    std::size_t frames = 0, tracked = 0;
    std::string error;
    auto save = [&] (const std::string& name) {
      const auto map = fusion.labelledCloud ();
      if (map->empty ())
        return;
      if (pcl::io::savePCDFileBinaryCompressed (out_dir + "/" + name, *map) != 0)
        throw std::runtime_error ("cannot write " + out_dir + "/" + name);
      std::cout << "frame " << frames << ": " << map->size () << " labelled points, "
                << fusion.segments ().size () << " segments -> " << out_dir << "/" << name << "\n";
    };
    // The grabber's callback: one frame in, the map updated.
    std::function<cuefusion::io::RGBDGrabber::sig_cb_rgbd_frame> on_frame =
      [&] (const cuefusion::RGBDFrame::ConstPtr& frame) {
        const std::lock_guard<std::mutex> lock (mutex);
        try
        {
          std::vector<cuefusion::Instance> instances;
          const bool have_masks = masks && masks->segment (*frame, instances);
          const cuefusion::pipeline::PipelineFrameReport report = fusion.process (*frame, have_masks ? &instances : nullptr);
          ++frames;
          tracked += report.reconstruction.tracked ? 1 : 0;
          if (frames % static_cast<std::size_t> (every) == 0)
          {
            char name[32];
            std::snprintf (name, sizeof (name), "map_%05zu.pcd", frames);
            save (name);
          }
        }
        catch (const std::exception& e)  // a camera's thread must not die with an exception
        {
          error = e.what ();
          g_stop = true;
        }
      };
    grabber->registerCallback (on_frame);
    grabber->start ();
    if (const auto dataset = std::dynamic_pointer_cast<cuefusion::io::DatasetGrabber> (grabber))
    {
      while (!g_stop && dataset->trigger ())  // recorded frames: one per trigger, none dropped
        ;
    }
    else
    {
      while (!g_stop && grabber->isRunning ())  // a camera calls back from its own thread
        std::this_thread::sleep_for (std::chrono::milliseconds (20));
    }
    grabber->stop ();
    const std::lock_guard<std::mutex> lock (mutex);
    if (!error.empty ())
    {
      std::cerr << "live_segmentation: " << error << "\n";
      return 1;
    }
    save ("map_final.pcd");
    std::cout << frames << " frames, " << tracked << " tracked\n";
    return frames > 0 ? 0 : 1;
  }
  catch (const std::exception& e)
  {
    std::cerr << "live_segmentation: " << e.what () << "\n";
    return 1;
  }
}
