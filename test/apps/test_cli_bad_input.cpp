// SPDX-License-Identifier: BSD-3-Clause
// Bad input across every command, as a new user meets it: each case must end with exit
// 1 (bad data) or 2 (bad usage), exactly one line on stderr naming the file or option,
// no crash, and no file written, changed or left behind (no partial or mixed output set).
#include "test_utils.h"

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>

using namespace cuefusion;
namespace fs = boost::filesystem;

namespace
{
/** Every file below \a root: relative path → contents. */
std::map<std::string, std::string>
snapshot (const fs::path& root)
{
  std::map<std::string, std::string> files;
  for (fs::recursive_directory_iterator it (root), end; it != end; ++it)
  {
    const std::string relative = it->path ().string ().substr (root.string ().size ());
    files[relative] = fs::is_regular_file (it->path ()) ? test::readFile (it->path ().string ()) : std::string ("<folder>");
  }
  return files;
}

std::string
pcdHeader (const std::string& fields, const std::string& size, const std::string& type, const std::string& count,
           int width, int height, const std::string& points, const std::string& data)
{
  return "# .PCD v0.7\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + size + "\nTYPE " + type + "\nCOUNT " + count +
         "\nWIDTH " + std::to_string (width) + "\nHEIGHT " + std::to_string (height) +
         "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
}

/** An organized 4×3 ASCII cloud whose header can be made to lie. */
std::string
pcd (const std::string& size = "4 4 4", const std::string& type = "F F F", const std::string& count = "1 1 1",
     const std::string& points = "12", const std::string& data = "ascii")
{
  std::string body;
  for (int i = 0; i < 12; ++i)
    body += std::to_string (0.01 * (i % 4)) + " " + std::to_string (0.01 * (i / 4)) + " 1\n";
  return pcdHeader ("x y z", size, type, count, 4, 3, points, data) + (data == "ascii" ? body : std::string ());
}

std::string
plyHeader (const std::string& elements)
{
  return "ply\nformat ascii 1.0\n" + elements + "end_header\n";
}

std::string
nested (int depth)
{
  return std::string (static_cast<std::size_t> (depth), '[') + std::string (static_cast<std::size_t> (depth), ']');
}

struct BadCase
{
  std::string name;
  /// Writes the case's files into its folder (D); may copy the fixtures.
  std::function<void (const std::string& d)> prepare;
  /// Arguments; {S} = a synthetic sequence, {R} = a run of it, {D} = the case's folder.
  std::string args;
  int code;
  std::string says;  ///< the file or option the line must name (after substitution)
};

class BadInputCli : public ::testing::Test
{
protected:
  static void
  SetUpTestSuite ()
  {
    fixtures = std::make_unique<test::TempDir> ();
    const test::TempDir& f = *fixtures;
    const std::string log = " >" + (f / "log.txt") + " 2>&1";
    ASSERT_EQ (std::system ((std::string (CUEFUSION_BINARY) + " synth --scene tabletop --frames 4 --size 64x48 --out " + (f / "seq") + log).c_str ()), 0);
    ASSERT_EQ (std::system ((std::string (CUEFUSION_BINARY) + " run " + (f / "seq") + " --frames 3 --out " + (f / "run") + log).c_str ()), 0);
  }
  static void
  TearDownTestSuite ()
  {
    fixtures.reset ();
  }
  static std::unique_ptr<test::TempDir> fixtures;
};
std::unique_ptr<test::TempDir> BadInputCli::fixtures;

std::string
substitute (std::string s, const std::string& seq, const std::string& run, const std::string& d)
{
  for (const auto& [key, value] : {std::pair<std::string, std::string> ("{S}", seq), {"{R}", run}, {"{D}", d}})
    for (std::size_t at; (at = s.find (key)) != std::string::npos;)
      s.replace (at, key.size (), value);
  return s;
}

void
copyTree (const fs::path& from, const fs::path& to)
{
  fs::create_directories (to);
  for (fs::directory_iterator it (from), end; it != end; ++it)
  {
    if (fs::is_directory (it->path ()))
      copyTree (it->path (), to / it->path ().filename ());
    else
      fs::copy_file (it->path (), to / it->path ().filename ());
  }
}

void
write (const std::string& path, const std::string& bytes)
{
  fs::create_directories (fs::path (path).parent_path ());
  test::writeFile (path, bytes);
}
}  // namespace

TEST_F (BadInputCli, EveryCaseIsOneLineNamingTheCulpritAndWritesNothing)
{
  const std::string S = *fixtures / "seq", R = *fixtures / "run";
  // Shorthands for the preparations.
  const auto file = [] (const std::string& name, const std::string& bytes) {
    return [=] (const std::string& d) { write (d + "/" + name, bytes); };
  };
  const auto runCopy = [&] (const std::string& name, const std::string& bytes) {
    return [=] (const std::string& d) {
      copyTree (R, d + "/run");
      write (d + "/run/" + name, bytes);
    };
  };
  const auto seqCopy = [&] (const std::function<void (const std::string& seq)>& change) {
    return [=] (const std::string& d) {
      copyTree (S, d + "/seq");
      change (d + "/seq");
    };
  };
  const auto first = [] (const std::string& folder, const std::string& ext) {
    std::vector<std::string> names;
    for (fs::directory_iterator it (folder), end; it != end; ++it)
      if (it->path ().extension () == ext)
        names.push_back (it->path ().string ());
    std::sort (names.begin (), names.end ());
    return names.front ();
  };
  const auto sidecar = [&] (const std::string& instances) {
    return seqCopy ([=] (const std::string& seq) { write (first (seq + "/detections", ".json"), "{\"instances\": [" + instances + "]}"); });
  };
  const std::uint32_t zero_sizes[2] = {0, 0};
  const std::string compressed_zero = pcdHeader ("x y z", "4 4 4", "F F F", "1 1 1", 4, 3, "12", "binary_compressed") +
                                      std::string (reinterpret_cast<const char*> (zero_sizes), 8);
  const std::string good_vertices = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string tri = "0 0 1\n1 0 1\n0 1 1\n";
  const std::string face_int = "element face 1\nproperty list uchar int vertex_indices\n";
  const std::string none = "";
  const auto nothing = [] (const std::string&) {};

  const std::vector<BadCase> cases = {
    // --- files that crashed (PCD, PLY, JSON)
    {"pcd count -1", file ("c.pcd", pcd ("4 4 4", "F F F", "1 -1 1")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd compressed 0/0", file ("c.pcd", compressed_zero), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd binary body short", file ("c.pcd", pcdHeader ("x y z", "4 4 4", "F F F", "1 1 1", 2, 2, "4", "binary") + std::string (13, '\0')),
     "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"eval map.pcd count -1", runCopy ("map.pcd", pcd ("4 4 4", "F F F", "1 -1 1")), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "map.pcd"},
    {"eval map.pcd compressed 0/0", runCopy ("map.pcd", compressed_zero), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "map.pcd"},
    {"eval gt_cloud.pcd compressed 0/0", seqCopy ([&] (const std::string& seq) { write (seq + "/gt_cloud.pcd", compressed_zero); }),
     "eval --run {R} --gt {D}/seq --out {D}/rep --no-plots", 1, "gt_cloud.pcd"},
    {"render ply float face list NaN", runCopy ("mesh.ply", plyHeader (good_vertices + "element face 1\nproperty list uchar float vertex_indices\n") + tri + "3 nan 0 1\n"),
     "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"eval ply float face list NaN", runCopy ("mesh.ply", plyHeader (good_vertices + "property uint label\nelement face 1\nproperty list uchar float vertex_indices\n") +
                                                           "0 0 1 1\n1 0 1 1\n0 1 1 1\n3 nan 0 1\n"),
     "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "mesh.ply"},
    {"render ply two vertex blocks", runCopy ("mesh.ply", plyHeader (good_vertices + good_vertices + face_int) + tri + tri + "3 0 1 2\n"),
     "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"render ply negative index", runCopy ("mesh.ply", plyHeader (good_vertices + face_int) + tri + "3 0 -1 2\n"), "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"render ply index past the vertices", runCopy ("mesh.ply", plyHeader (good_vertices + face_int) + tri + "3 0 1 3\n"), "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"render ply 1e9 vertices in 3 KB", runCopy ("mesh.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n" + std::string (3000, '\0')),
     "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"render ply not a ply", runCopy ("mesh.ply", "solid cube\nendsolid\n"), "render --run {D}/run --views 1 --size 32x24", 1, "mesh.ply"},
    {"eval segments.json nested 1e6 deep", runCopy ("segments.json", "{\"segments\": " + nested (1000000) + "}"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"eval segments.json id 4.7", runCopy ("segments.json", "{\"segments\": [{\"id\": 4.7}]}"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"eval segments.json id -5", runCopy ("segments.json", "{\"segments\": [{\"id\": -5}]}"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"eval segments.json score 7", runCopy ("segments.json", "{\"segments\": [{\"id\": 3, \"score\": 7}]}"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"eval segments.json not a list", runCopy ("segments.json", "{\"segments\": 3}"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"eval segments.json not JSON", runCopy ("segments.json", "{\"segments\": [ {"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    // --- garbage that was accepted
    {"pcd type Q", file ("c.pcd", pcd ("4 4 4", "F Q F")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd size 0", file ("c.pcd", pcd ("4 0 4")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd size 3", file ("c.pcd", pcd ("4 3 4")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd integer xyz", file ("c.pcd", pcd ("4 4 4", "I I I")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd points != width*height", file ("c.pcd", pcd ("4 4 4", "F F F", "1 1 1", "11")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd unknown data", file ("c.pcd", pcd ("4 4 4", "F F F", "1 1 1", "12", "zip")), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd empty file", file ("c.pcd", ""), "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"pcd no x field", file ("c.pcd", pcdHeader ("a b c", "4 4 4", "F F F", "1 1 1", 1, 1, "1", "ascii") + "1 2 3\n"),
     "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"sidecar score -5", sidecar ("{\"id\": 1, \"score\": -5}"), "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".json"},
    {"sidecar score 1e300", sidecar ("{\"id\": 1, \"score\": 1e300}"), "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".json"},
    {"sidecar class_id 1e20", sidecar ("{\"id\": 1, \"class_id\": 1e20}"), "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".json"},
    {"sidecar id 4.7", sidecar ("{\"id\": 4.7}"), "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".json"},
    {"sidecar not JSON", sidecar ("{"), "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".json"},
    {"intrinsics fx 1e-300", file ("k.txt", "1e-300 52.5 31.5 23.5 64 48\n"), "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"intrinsics width 2^32+320", file ("k.json", "{\"width\": 4294967616, \"height\": 48, \"intrinsic_matrix\": [52.5,0,0,0,52.5,0,31.5,23.5,1]}"),
     "run {S} --intrinsics {D}/k.json --out {D}/o", 1, "k.json"},
    {"intrinsics width a string", file ("k.json", "{\"width\": \"wide\", \"height\": 48, \"intrinsic_matrix\": [52.5,0,0,0,52.5,0,31.5,23.5,1]}"),
     "run {S} --intrinsics {D}/k.json --out {D}/o", 1, "k.json"},
    {"intrinsics NaN", file ("k.txt", "nan 52.5 31.5 23.5 64 48\n"), "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"intrinsics words", file ("k.txt", "fx fy cx cy\n"), "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"intrinsics for another size", file ("k.txt", "525 525 319.5 239.5 640 480\n"), "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "640x480"},
    {"run --frames -5", nothing, "run {S} --out {D}/o --frames -5", 2, "--frames"},
    {"run --save-every -1", nothing, "run {S} --out {D}/o --save-every -1", 2, "--save-every"},
    {"synth --size 0x0", nothing, "synth --scene tabletop --out {D}/o --size 0x0", 2, "--size"},
    {"eval per-frame without labels/", nothing, "eval --run {R} --gt {S} --out {D}/rep --labels per-frame --no-plots", 1, "labels"},
    // --- blow-ups and unclear errors
    {"scannet stem of 30 digits", [] (const std::string& d) {  // a number too long for any integer
       const std::string stem = "123456789012345678901234567890";
       for (const char* sub : {"depth", "color"})
         fs::create_directories (d + "/sn/" + sub);
       cv::imwrite (d + "/sn/depth/" + stem + ".png", cv::Mat (48, 64, CV_16UC1, cv::Scalar (1000)));
       cv::imwrite (d + "/sn/color/" + stem + ".jpg", cv::Mat (48, 64, CV_8UC3, cv::Scalar (1, 2, 3)));
       write (d + "/sn/intrinsic/intrinsic_depth.txt", "52.5 0 31.5 0\n0 52.5 23.5 0\n0 0 1 0\n0 0 0 1\n");
     },
     "info {D}/sn", 1, "123456789012345678901234567890"},
    {"depth png corrupt (libpng)", seqCopy ([&] (const std::string& seq) {
       std::string bytes = test::readFile (first (seq + "/depth", ".png"));
       bytes[bytes.find ("IDAT") + 10] ^= 0x7f;
       write (first (seq + "/depth", ".png"), bytes);
     }),
     "run {D}/seq --out {D}/o", 1, ".png"},
    {"depth png truncated", seqCopy ([&] (const std::string& seq) {
       const std::string bytes = test::readFile (first (seq + "/depth", ".png"));
       write (first (seq + "/depth", ".png"), bytes.substr (0, bytes.size () / 2));
     }),
     "run {D}/seq --out {D}/o", 1, "truncated"},
    {"depth png 8-bit colour", seqCopy ([&] (const std::string& seq) {
       cv::imwrite (first (seq + "/depth", ".png"), cv::Mat (48, 64, CV_8UC3, cv::Scalar (1, 2, 3)));
     }),
     "run {D}/seq --out {D}/o", 1, ".png"},
    {"tum list garbage", seqCopy ([] (const std::string& seq) { write (seq + "/depth.txt", "1.0 depth/missing.png\nrubbish\n"); }), "run {D}/seq --out {D}/o", 1, "depth"},
    {"ground truth poses garbage", seqCopy ([] (const std::string& seq) { write (seq + "/groundtruth.txt", "1.0 1 2 3\n"); }), "run {D}/seq --out {D}/o", 1, "groundtruth.txt"},
    {"ground truth poses 100 km away", seqCopy ([] (const std::string& seq) {
       std::istringstream in (test::readFile (seq + "/groundtruth.txt"));
       std::string line, moved;
       while (std::getline (in, line))
       {
         std::istringstream fields (line);
         double stamp = 0, x = 0;
         std::string rest;
         if (line.empty () || line[0] == '#' || !(fields >> stamp >> x) || !std::getline (fields, rest))
           moved += line + "\n";
         else
           moved += std::to_string (stamp) + " " + std::to_string (x + 1e5) + rest + "\n";
       }
       write (seq + "/groundtruth.txt", moved);
     }),
     "run {D}/seq --out {D}/o --use-gt-poses", 1, "groundtruth.txt: frame"},
    {"scene.json not JSON", seqCopy ([] (const std::string& seq) { write (seq + "/scene.json", "{"); }), "eval --run {R} --gt {D}/seq --out {D}/rep --no-plots", 1, "scene.json"},
    // --- outputs
    {"run --out is a file", file ("o", "x"), "run {S} --out {D}/o", 1, "/o"},
    {"run --video in a folder that cannot be made", file ("f", "x"), "run {S} --out {D}/o --video {D}/f/v.mp4", 1, "v.mp4"},
    {"segment-frame --out /dev/null", file ("c.pcd", pcd ()), "segment-frame {D}/c.pcd --out /dev/null", 1, "/dev/null"},
    {"segment-frame --out a folder", [&] (const std::string& d) {
       write (d + "/c.pcd", pcd ());
       fs::create_directories (d + "/o.pcd");
     },
     "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "o.pcd"},
    {"eval --out is a file", file ("rep", "x"), "eval --run {R} --gt {S} --out {D}/rep --no-plots", 1, "rep"},
    {"run --video bad extension", nothing, "run {S} --out {D}/o --video {D}/v.gif", 2, "--video"},
    {"run --video over a folder", [] (const std::string& d) { fs::create_directories (d + "/v.avi"); }, "run {S} --out {D}/o --video {D}/v.avi", 1, "v.avi"},
    {"synth --out is a file", file ("o", "x"), "synth --scene tabletop --frames 2 --size 32x24 --out {D}/o --overwrite", 1, "/o"},
    {"synth --out /dev/null", nothing, "synth --scene tabletop --frames 2 --size 32x24 --out /dev/null --overwrite", 1, "/dev/null"},
    // --- every command's usual mistakes
    {"info missing", nothing, "info {D}/nope", 1, "nope"},
    {"info empty folder", [] (const std::string& d) { fs::create_directories (d + "/empty"); }, "info {D}/empty", 1, "empty"},
    {"info a file", file ("f.txt", "hello"), "info {D}/f.txt", 1, "f.txt"},
    {"run unknown format", nothing, "run {S} --out {D}/o --format kinectfusion", 2, "--format"},
    {"run --voxel 0", nothing, "run {S} --out {D}/o --voxel 0", 2, "--voxel"},
    {"run --config a misspelt field", file ("c.json", "{\"pipeline\": {\"reconstruction\": {\"volume\": {\"voxel_sise\": 0.02}}}}"),
     "run {S} --out {D}/o --config {D}/c.json", 1, "c.json: pipeline.reconstruction.volume.voxel_sise"},
    {"run --config a number for a name", file ("c.json", "{\"pipeline\": {\"mode\": 3}}"), "run {S} --out {D}/o --config {D}/c.json", 1, "pipeline.mode"},
    {"run --config -1 for a count", file ("c.json", "{\"pipeline\": {\"reconstruction\": {\"hole_refresh_period\": -1}}}"),
     "run {S} --out {D}/o --config {D}/c.json", 1, "hole_refresh_period"},
    {"run --config voxel 0", file ("c.json", "{\"pipeline\": {\"reconstruction\": {\"volume\": {\"voxel_size\": 0}}}}"),
     "run {S} --out {D}/o --config {D}/c.json", 1, "c.json: pipeline (TSDFVolumeConfig::voxel_size)"},
    {"run --config not JSON", file ("c.json", "{\"pipeline\": "), "run {S} --out {D}/o --config {D}/c.json", 1, "c.json"},
    {"segment-frame --config of run", file ("c.json", "{\"pipeline\": {}}"), "segment-frame {S} --out {D}/o --config {D}/c.json", 1, "c.json: pipeline"},
    {"run --truncation 100", nothing, "run {S} --out {D}/o --truncation 100", 2, "--truncation"},
    {"run --max-depth -1", nothing, "run {S} --out {D}/o --max-depth -1", 2, "--max-depth"},
    {"run --mode masks without masks", nothing, "run {S} --out {D}/o --mode masks", 2, "--mode"},
    {"run --masks and --model", nothing, "run {S} --out {D}/o --masks {S}/detections --model x.onnx", 2, "--model"},
    {"run --model missing", nothing, "run {S} --out {D}/o --model {D}/none.onnx", 1, "none.onnx"},
    {"run --model garbage", file ("m.onnx", "not a network"), "run {S} --out {D}/o --model {D}/m.onnx", 1, "m.onnx"},
    {"run --masks missing folder", nothing, "run {S} --out {D}/o --masks {D}/nomasks", 1, "nomasks"},
    {"run --score-threshold 2", nothing, "run {S} --out {D}/o --model x.onnx --score-threshold 2", 2, "--score-threshold"},
    {"run --hole-refresh 0", nothing, "run {S} --out {D}/o --hole-refresh 0", 2, "--hole-refresh"},
    {"run --view-screenshot without --view", nothing, "run {S} --out {D}/o --view-screenshot {D}/s.png", 2, "--view"},
    {"segment-frame missing input", nothing, "segment-frame {D}/none.pcd --out {D}/o.pcd", 1, "none.pcd"},
    {"segment-frame png without intrinsics", [&] (const std::string& d) { fs::copy_file (first (S + "/depth", ".png"), d + "/d.png"); },
     "segment-frame {D}/d.png --out {D}/o.pcd", 2, "--intrinsics"},
    {"segment-frame unorganized cloud", file ("c.pcd", pcdHeader ("x y z", "4 4 4", "F F F", "1 1 1", 3, 1, "3", "ascii") + tri),
     "segment-frame {D}/c.pcd --out {D}/o.pcd", 1, "c.pcd"},
    {"segment-frame rgb of another size", [&] (const std::string& d) {
       write (d + "/c.pcd", pcd ());
       cv::imwrite (d + "/rgb.png", cv::Mat (10, 10, CV_8UC3, cv::Scalar (1, 2, 3)));
     },
     "segment-frame {D}/c.pcd --rgb {D}/rgb.png --out {D}/o.pcd", 1, "rgb.png"},
    {"segment-frame masks not an image", [&] (const std::string& d) {
       write (d + "/c.pcd", pcd ());
       write (d + "/m.png", "not a png");
     },
     "segment-frame {D}/c.pcd --masks {D}/m.png --out {D}/o.pcd", 1, "m.png"},
    {"eval --gt missing", nothing, "eval --run {R} --gt {D}/nogt --out {D}/rep", 1, "nogt"},
    {"eval --run missing", nothing, "eval --run {D}/norun --gt {S} --out {D}/rep", 1, "norun"},
    {"eval trajectory garbage", runCopy ("trajectory.txt", "1.0 a b c d e f g\n"), "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "trajectory.txt"},
    {"eval mesh.ply missing", [&] (const std::string& d) {
       copyTree (R, d + "/run");
       fs::remove (d + "/run/mesh.ply");
     },
     "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "mesh.ply"},
    {"eval --every 0", nothing, "eval --run {R} --gt {S} --out {D}/rep --every 0", 2, "--every"},
    {"eval --labels other", nothing, "eval --run {R} --gt {S} --out {D}/rep --labels sometimes", 2, "--labels"},
    {"render --run missing", nothing, "render --run {D}/norun", 1, "norun"},
    {"render --size 0x0", nothing, "render --run {R} --size 0x0", 2, "--size"},
    {"render --views 0", nothing, "render --run {R} --views 0", 2, "--views"},
    {"render --min-piece -1", nothing, "render --run {R} --min-piece -1 --out {D}/r", 2, "--min-piece"},
    {"render --from cameras without trajectory.txt", [&] (const std::string& d) {
       copyTree (R, d + "/run");
       fs::remove (d + "/run/trajectory.txt");
     },
     "render --run {D}/run --from cameras --views 1 --size 32x24", 1, "trajectory.txt"},
    {"render --from cameras with an empty trajectory.txt", runCopy ("trajectory.txt", ""), "render --run {D}/run --from cameras --views 1 --size 32x24", 1, "trajectory.txt"},
    {"synth scene missing", nothing, "synth --scene {D}/none.scene --out {D}/o", 1, "none.scene"},
    {"synth scene syntax error", file ("bad.scene", "object thing\n  pyramid center=0,0,0\n"), "synth --scene {D}/bad.scene --out {D}/o", 1, "bad.scene"},
    {"synth --layout nope", nothing, "synth --scene tabletop --out {D}/o --layout nope", 2, "--layout"},
    {"synth --mask-merge 1.5", nothing, "synth --scene tabletop --out {D}/o --mask-merge 1.5", 2, "--mask-merge"},
    {"synth-views --views 0", nothing, "synth-views --views 0 --out {D}/o", 2, "--views"},
    {"synth-views --touching 2", nothing, "synth-views --views 2 --out {D}/o --touching 2", 2, "--touching"},
    {"synth-views --size 1x1", nothing, "synth-views --views 2 --out {D}/o --size 1x1", 2, "--size"},
    // --- inputs that are not regular files: read without end or blocking forever before
    {"depth png is a FIFO", [&] (const std::string& d) { ASSERT_EQ (mkfifo ((d + "/f.png").c_str (), 0600), 0); write (d + "/k.txt", "52.5 52.5 31.5 23.5 64 48\n"); },
     "segment-frame {D}/f.png --intrinsics {D}/k.txt --out {D}/o.pcd", 1, "f.png"},
    {"intrinsics is a FIFO", [&] (const std::string& d) { ASSERT_EQ (mkfifo ((d + "/k.txt").c_str (), 0600), 0); },
     "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"intrinsics link to /dev/zero", [&] (const std::string& d) { fs::create_symlink ("/dev/zero", d + "/k.txt"); },
     "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"segments.json is a FIFO", [&] (const std::string& d) {
       copyTree (R, d + "/run");
       fs::remove (d + "/run/segments.json");
       ASSERT_EQ (mkfifo ((d + "/run/segments.json").c_str (), 0600), 0);
     },
     "eval --run {D}/run --gt {S} --out {D}/rep --no-plots", 1, "segments.json"},
    {"@list is /dev/zero", [&] (const std::string& d) { fs::create_symlink ("/dev/zero", d + "/list.txt"); },
     "batch @{D}/list.txt --out {D}/o", 1, "list.txt"},
    {"mask png link to /dev/zero", seqCopy ([&] (const std::string& seq) {
       const std::string png = first (seq + "/detections", ".png");
       fs::remove (png);
       fs::create_symlink ("/dev/zero", png);
     }),
     "run {D}/seq --masks {D}/seq/detections --out {D}/o", 1, ".png"},
    // --- outputs onto inputs
    {"segment-frame --png onto its input", [&] (const std::string& d) { fs::copy_file (first (S + "/depth", ".png"), d + "/d.png"); write (d + "/k.txt", "52.5 52.5 31.5 23.5 64 48\n"); },
     "segment-frame {D}/d.png --intrinsics {D}/k.txt --out {D}/o.pcd --png {D}/./d.png", 2, "--png"},
    {"segment-frame DIR --out DIR", [&] (const std::string& d) { fs::create_directories (d + "/in"); fs::copy_file (first (S + "/depth", ".png"), d + "/in/d.png"); write (d + "/k.txt", "52.5 52.5 31.5 23.5 64 48\n"); },
     "segment-frame {D}/in --intrinsics {D}/k.txt --out {D}/in/", 2, "--out"},
    {"run --load-volume X/volume.tsdf --out X without --save-volume", [&] (const std::string& d) {
       ASSERT_EQ (std::system ((std::string (CUEFUSION_BINARY) + " run " + S + " --frames 2 --save-volume --out " + d + "/v >/dev/null 2>&1").c_str ()), 0);
     },
     "run {S} --load-volume {D}/v/volume.tsdf --out {D}/v", 2, "--out"},
    // --- numbers out of range that wrapped or crashed
    {"eval --min-pixels -1", nothing, "eval --run {R} --gt {S} --out {D}/rep --min-pixels=-1", 2, "--min-pixels"},
    {"eval --min-region -5", nothing, "eval --run {R} --gt {S} --out {D}/rep --min-region=-5", 2, "--min-region"},
    {"eval --every -3", nothing, "eval --run {R} --gt {S} --out {D}/rep --every=-3", 2, "--every"},
    {"segment-frame --normal-smoothing 200 on 64x48", [&] (const std::string& d) { fs::copy_file (first (S + "/depth", ".png"), d + "/d.png"); write (d + "/k.txt", "52.5 52.5 31.5 23.5 64 48\n"); },
     "segment-frame {D}/d.png --intrinsics {D}/k.txt --normals integral --normal-smoothing 200 --out {D}/o.pcd", 2, "--normal-smoothing"},
    {"intrinsics principal point 10^6 px", file ("k.txt", "52.5 52.5 1000000 23.5 64 48\n"), "run {S} --intrinsics {D}/k.txt --out {D}/o", 1, "k.txt"},
    {"eval --aggregate of one folder twice", [&] (const std::string& d) {
       ASSERT_EQ (std::system ((std::string (CUEFUSION_BINARY) + " eval --run " + R + " --gt " + S + " --out " + d + "/rep --no-plots >/dev/null 2>&1").c_str ()), 0);
     },
     "eval --aggregate {D}/rep {D}/rep/ --out {D}/sum --no-plots", 2, "rep"},
  };
  ASSERT_GE (cases.size (), 60u);
  const std::map<std::string, std::string> fixtures_before = snapshot (fixtures->str ());
  for (const BadCase& c : cases)
  {
    SCOPED_TRACE (c.name);
    test::TempDir d;
    fs::create_directories (d / "case");
    const std::string D = d / "case";
    c.prepare (D);
    const std::map<std::string, std::string> before = snapshot (D);
    const std::string args = substitute (c.args, S, R, D);
    // (a bound, so a case that blocks fails instead of hanging the suite)
    const std::string command = "timeout -s KILL 120 " + std::string (CUEFUSION_BINARY) + " " + args + " >" + (d / "out.txt") + " 2>" + (d / "err.txt") + " </dev/null";
    const int status = std::system (command.c_str ());
    ASSERT_TRUE (WIFEXITED (status)) << args << ": killed by a signal";
    const std::string err = test::readFile (d / "err.txt");
    EXPECT_EQ (WEXITSTATUS (status), c.code) << args << "\n" << err;
    EXPECT_EQ (std::count (err.begin (), err.end (), '\n'), 1) << args << "\n" << err;
    EXPECT_NE (err.find (substitute (c.says, S, R, D)), std::string::npos) << args << "\n" << err;
    EXPECT_EQ (err.find ("unexpected error"), std::string::npos) << err;
    EXPECT_TRUE (snapshot (D) == before) << args << ": files were written, changed or left behind";
  }
  EXPECT_TRUE (snapshot (fixtures->str ()) == fixtures_before);
}
