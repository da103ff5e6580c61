// SPDX-License-Identifier: BSD-3-Clause
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/io/camera_io.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>
#include <cuefusion/io/mesh_io.h>
#include <cuefusion/io/pose_io.h>
#include <cuefusion/segmentation/segments_file.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <functional>
#include <memory>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

using namespace cuefusion;
using cuefusion::test::TempDir;

TEST (CameraIO, IntrinsicsRoundTripInEveryLayout)
{
  TempDir dir;
  const PinholeCamera cam (585.25, 584.5, 320.125, 239.75, 640, 480);
  io::writeIntrinsicsJson (dir / "k.json", cam);
  EXPECT_TRUE (io::readIntrinsics (dir / "k.json") == cam);
  io::writeIntrinsicsLine (dir / "k.txt", cam);
  EXPECT_TRUE (io::readIntrinsics (dir / "k.txt") == cam);
  for (int rows : {3, 4})
  {
    io::writeIntrinsicsMatrix (dir / "m.txt", cam, rows);
    const PinholeCamera back = io::readIntrinsics (dir / "m.txt");
    EXPECT_EQ (back.fx, cam.fx);
    EXPECT_EQ (back.fy, cam.fy);
    EXPECT_EQ (back.cx, cam.cx);
    EXPECT_EQ (back.cy, cam.cy);
    EXPECT_EQ (back.width, 0);  // matrices carry no size; grabbers take it from the images
  }
}

TEST (CameraIO, ReadsOpen3DColumnMajorJson)
{
  TempDir dir;
  test::writeFile (dir / "camera_intrinsics.json",
                   "{\"width\": 640, \"height\": 480, \"intrinsic_matrix\": [525, 0, 0, 0, 520, 0, 319.5, 239.5, 1]}");
  const PinholeCamera cam = io::readIntrinsics (dir / "camera_intrinsics.json");
  EXPECT_EQ (cam.fx, 525.0);
  EXPECT_EQ (cam.fy, 520.0);
  EXPECT_EQ (cam.cx, 319.5);
  EXPECT_EQ (cam.cy, 239.5);
  EXPECT_EQ (cam.width, 640);
}

TEST (FileIO, DepthRoundTripIsExactToOneUnit)
{
  TempDir dir;
  cv::Mat depth (4, 5, CV_32F);
  cv::randu (depth, 0.3, 6.0);
  depth.at<float> (0, 0) = 0.f;
  depth.at<float> (1, 1) = std::numeric_limits<float>::quiet_NaN ();
  io::writeImageAtomic (dir / "d.png", io::depthToRaw (depth, 5000.0));
  const cv::Mat back = io::readDepthImage (dir / "d.png", 5000.0);
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
    {
      const float z = depth.at<float> (v, u);
      if (isValidDepth (z))
        EXPECT_NEAR (back.at<float> (v, u), z, 0.5 / 5000.0 + 1e-6);
      else
        EXPECT_EQ (back.at<float> (v, u), 0.f);
    }
}

TEST (FileIO, TruncatedImagesAreReportedByName)
{
  TempDir dir;
  cv::Mat image (64, 64, CV_16U);
  cv::randu (image, 0, 65535);
  io::writeImageAtomic (dir / "full.png", image);
  const std::string bytes = test::readFile (dir / "full.png");
  test::writeFile (dir / "cut.png", bytes.substr (0, bytes.size () / 2));
  try
  {
    io::readDepthImage (dir / "cut.png", 1000.0);
    FAIL () << "truncated PNG accepted";
  }
  catch (const Error& e)
  {
    EXPECT_NE (std::string (e.what ()).find ("cut.png"), std::string::npos);
  }
  test::writeFile (dir / "junk.png", "not an image at all");
  EXPECT_THROW (io::readImage (dir / "junk.png", -1), Error);
  EXPECT_THROW (io::readImage (dir / "missing.png", -1), Error);
}

TEST (PoseIO, MatrixFilesAndRedwoodLogRoundTrip)
{
  TempDir dir;
  io::PoseList poses;
  for (int i = 0; i < 3; ++i)
  {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity ();
    p.rotate (Eigen::AngleAxisd (0.3 * i + 0.1, Eigen::Vector3d (1, 2, 3).normalized ()));
    p.translation () = Eigen::Vector3d (i, -0.5 * i, 0.25);
    poses.push_back (p);
  }
  io::writePoseMatrixFile (dir / "p.txt", poses[1]);
  EXPECT_TRUE (io::readPoseMatrixFile (dir / "p.txt")->isApprox (poses[1], 1e-12));
  io::writeRedwoodLog (dir / "t.log", poses);
  const io::PoseList back = io::readRedwoodLog (dir / "t.log");
  ASSERT_EQ (back.size (), poses.size ());
  for (std::size_t i = 0; i < poses.size (); ++i)
    EXPECT_TRUE (back[i].isApprox (poses[i], 1e-12));
}

TEST (PoseIO, InfinitePoseMeansNoPose)
{
  TempDir dir;
  test::writeFile (dir / "p.txt", "-inf -inf -inf -inf\n-inf -inf -inf -inf\n-inf -inf -inf -inf\n-inf -inf -inf -inf\n");
  EXPECT_FALSE (io::readPoseMatrixFile (dir / "p.txt").has_value ());
}

TEST (PoseIO, RejectsNonRigidMatrix)
{
  TempDir dir;
  test::writeFile (dir / "p.txt", "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  EXPECT_THROW (io::readPoseMatrixFile (dir / "p.txt"), Error);
}

namespace
{
std::vector<std::string>
entries (const std::string& dir)
{
  std::vector<std::string> names;
  for (boost::filesystem::directory_iterator it (dir), end; it != end; ++it)
    names.push_back (it->path ().filename ().string ());
  std::sort (names.begin (), names.end ());
  return names;
}
}  // namespace

TEST (FileIO, AtomicWriteThatThrowsLeavesNoTemporaryAndRefusesDevices)
{
  TempDir dir;
  test::writeFile (dir / "a.txt", "old");
  EXPECT_THROW (io::writeFileAtomic (dir / "a.txt",
                                     [] (const std::string& tmp) -> bool {
                                       test::writeFile (tmp, "half");
                                       throw std::runtime_error ("writer failed");
                                     }),
                std::runtime_error);
  EXPECT_EQ (test::readFile (dir / "a.txt"), "old");
  EXPECT_EQ (entries (dir.str ()), std::vector<std::string> ({"a.txt"}));
  // A device is never replaced by a regular file, nor a folder.
  test::expectError ([] { io::writeTextAtomic ("/dev/null", "x"); }, "/dev/null", "not a regular file");
  boost::filesystem::create_directory (dir / "folder");
  test::expectError ([&] { io::writeTextAtomic (dir / "folder", "x"); }, "folder", "is a folder");
}

TEST (FileIO, OutputSetReplacesThePreviousSetAsAWhole)
{
  TempDir dir;
  const std::string out = dir / "out";
  const std::vector<std::string> owned = {"a.txt", "b.txt", "extra", "done.json"};
  {
    io::OutputSet set (out, owned, "done.json");
    io::writeTextAtomic (set.stagingPath ("a.txt"), "a1");
    io::writeTextAtomic (set.stagingPath ("extra/x.txt"), "x1");
    // Nothing is visible before the commit.
    EXPECT_FALSE (boost::filesystem::exists (set.finalPath ("a.txt")));
    io::writeTextAtomic (set.stagingPath ("done.json"), "1");
    set.commit ();
  }
  test::writeFile (dir / "out/user.txt", "mine");  // not the command's: never touched
  EXPECT_EQ (entries (out), std::vector<std::string> ({"a.txt", "done.json", "extra", "user.txt"}));

  // Abandoned (an error, a second signal): the previous set stays, the staging folder goes.
  {
    io::OutputSet set (out, owned, "done.json");
    io::writeTextAtomic (set.stagingPath ("a.txt"), "a2");
    EXPECT_EQ (entries (out).size (), 5u);  // the staging folder
  }
  EXPECT_EQ (entries (out), std::vector<std::string> ({"a.txt", "done.json", "extra", "user.txt"}));
  EXPECT_EQ (test::readFile (dir / "out/a.txt"), "a1");

  // A new set without "extra" removes the old one's: no files of two sets side by side.
  {
    io::OutputSet set (out, owned, "done.json");
    io::writeTextAtomic (set.stagingPath ("a.txt"), "a3");
    io::writeTextAtomic (set.stagingPath ("b.txt"), "b3");
    io::writeTextAtomic (set.stagingPath ("done.json"), "3");
    set.commit ();
  }
  EXPECT_EQ (entries (out), std::vector<std::string> ({"a.txt", "b.txt", "done.json", "user.txt"}));
  EXPECT_EQ (test::readFile (dir / "out/a.txt"), "a3");
  EXPECT_EQ (test::readFile (dir / "out/done.json"), "3");

  // A staging folder of a process that no longer runs (killed while writing) is removed.
  boost::filesystem::create_directories (dir / "out/.cuefusion-staging-999999999-abcdef/sub");
  {
    io::OutputSet set (out, owned, "done.json");
  }
  EXPECT_EQ (entries (out), std::vector<std::string> ({"a.txt", "b.txt", "done.json", "user.txt"}));

  // An output that would replace a folder with a file is refused before anything moves.
  boost::filesystem::remove (dir / "out/b.txt");
  boost::filesystem::create_directory (dir / "out/b.txt");
  {
    io::OutputSet set (out, owned, "done.json");
    io::writeTextAtomic (set.stagingPath ("a.txt"), "a4");
    io::writeTextAtomic (set.stagingPath ("b.txt"), "b4");
    io::writeTextAtomic (set.stagingPath ("done.json"), "4");
    test::expectError ([&] { set.commit (); }, "b.txt", "refusing to replace it");
  }
  EXPECT_EQ (test::readFile (dir / "out/a.txt"), "a3");
  EXPECT_EQ (test::readFile (dir / "out/done.json"), "3");
}

TEST (FileIO, ReadersRefuseFoldersDevicesAndPipesByName)
{
  // A FIFO blocks the first read forever and /dev/zero never ends: each reader refuses
  // them (and folders) before opening, naming the path.
  TempDir dir;
  const std::string fifo = dir / "pipe", zero = dir / "zero", folder = dir / "folder";
  ASSERT_EQ (mkfifo (fifo.c_str (), 0600), 0);
  boost::filesystem::create_symlink ("/dev/zero", zero);
  boost::filesystem::create_directories (folder);
  const std::vector<std::pair<std::string, std::function<void (const std::string&)>>> readers = {
    {"readTextFile", [] (const std::string& p) { io::readTextFile (p); }},
    {"readJsonFile", [] (const std::string& p) { io::readJsonFile (p); }},
    {"readImage", [] (const std::string& p) { io::readImage (p, -1); }},
    {"readIntrinsics", [] (const std::string& p) { io::readIntrinsics (p); }},
    {"readTumTrajectory", [] (const std::string& p) { io::readTumTrajectory (p); }},
    {"readPCD", [] (const std::string& p) { io::readPCD (p); }},
    {"readSegmentsJson", [] (const std::string& p) { segmentation::readSegmentsJson (p); }},
    {"readMeshPLY", [] (const std::string& p) { io::readMeshPLY (p); }},
  };
  for (const auto& [name, read] : readers)
  {
    SCOPED_TRACE (name);
    test::expectError ([&] { read (fifo); }, "pipe", "is a pipe (FIFO)");
    test::expectError ([&] { read (zero); }, "zero", "is a device");
    test::expectError ([&] { read (folder); }, "folder", "is a folder");
  }
  test::writeFile (dir / "plain.txt", "12345");
  boost::filesystem::create_symlink (dir / "plain.txt", dir / "link.txt");
  EXPECT_EQ (io::requireRegularFile (dir / "link.txt"), 5u);  // a link to a regular file is one
  test::expectError ([&] { io::requireRegularFile (dir / "missing"); }, "missing", "no such file");
}

TEST (FileIO, OneOutputSetAtATimeWritesIntoAFolder)
{
  // Two commands writing into one folder at once left one's outputs.json beside the
  // other's files: the second is refused while the first holds the folder.
  TempDir dir;
  const std::string out = dir / "out";
  {
    io::OutputSet first (out, {"a.txt", "done.json"}, "done.json");
    io::writeTextAtomic (first.stagingPath ("a.txt"), "first");
    test::expectError ([&] { io::OutputSet second (out, {"a.txt", "done.json"}, "done.json"); }, "out", "another cuefusion command");
    io::writeTextAtomic (first.stagingPath ("done.json"), "{}");
    first.commit ();
  }
  EXPECT_EQ (test::readFile (dir / "out/a.txt"), "first");
  io::OutputSet next (out, {"a.txt", "done.json"}, "done.json");  // free again once the first is done
  std::size_t entries = 0;
  for (boost::filesystem::directory_iterator it (out), end; it != end; ++it)
    entries += it->path ().filename ().string ().rfind (".cuefusion-staging", 0) == 0 ? 0 : 1;
  EXPECT_EQ (entries, 2u);  // the lock left no file behind
}

TEST (FileIO, ACommitKilledHalfWayGetsThePreviousSetBack)
{
  // The state a SIGKILL inside OutputSet::commit leaves: the old marker and an old file
  // moved aside into the staging folder's .previous/, one new file moved in (replacing
  // an old one) and one new-only file moved in, the new marker still staged. The next
  // writer puts the complete previous set back before it starts.
  TempDir dir;
  const std::string out = dir / "out";
  {
    io::OutputSet previous (out, {"a.txt", "keep.txt", "b.txt", "done.json"}, "done.json");
    io::writeTextAtomic (previous.stagingPath ("a.txt"), "old a");
    io::writeTextAtomic (previous.stagingPath ("keep.txt"), "old keep");
    io::writeTextAtomic (previous.stagingPath ("done.json"), "old");
    previous.commit ();
  }
  test::writeFile (dir / "out/mine.txt", "not cuefusion's");
  const pid_t dead = fork ();
  if (dead == 0)
    _exit (0);
  waitpid (dead, nullptr, 0);
  const std::string staging = out + "/.cuefusion-staging-" + std::to_string (dead) + "-abcdef";
  boost::filesystem::create_directories (staging + "/.previous");
  test::writeFile (staging + "/.journal", "done.json\na.txt\nb.txt\nkeep.txt\n");
  boost::filesystem::rename (out + "/done.json", staging + "/.previous/done.json");
  boost::filesystem::rename (out + "/a.txt", staging + "/.previous/a.txt");
  test::writeFile (out + "/a.txt", "new a");   // moved in
  test::writeFile (out + "/b.txt", "new b");   // moved in, had no old counterpart
  test::writeFile (staging + "/keep.txt", "new keep");  // not moved yet
  test::writeFile (staging + "/done.json", "new");      // the marker never arrived

  std::unique_ptr<io::OutputSet> next = std::make_unique<io::OutputSet> (out, std::vector<std::string>{"a.txt", "keep.txt", "b.txt", "done.json"}, "done.json");
  EXPECT_EQ (test::readFile (out + "/done.json"), "old");
  EXPECT_EQ (test::readFile (out + "/a.txt"), "old a");
  EXPECT_EQ (test::readFile (out + "/keep.txt"), "old keep");
  EXPECT_FALSE (boost::filesystem::exists (out + "/b.txt"));
  EXPECT_EQ (test::readFile (out + "/mine.txt"), "not cuefusion's");
  EXPECT_FALSE (boost::filesystem::exists (staging));
  next.reset ();

  // A commit that finished (its marker moved in) but was killed before removing its
  // staging folder: the folder is simply removed, the new set stays.
  const std::string finished = out + "/.cuefusion-staging-" + std::to_string (dead) + "-fedcba";
  boost::filesystem::create_directories (finished + "/.previous");
  test::writeFile (finished + "/.journal", "done.json\na.txt\n");
  test::writeFile (finished + "/.previous/a.txt", "older");
  {
    io::OutputSet after (out, {"a.txt", "done.json"}, "done.json");
  }
  EXPECT_EQ (test::readFile (out + "/a.txt"), "old a");
  EXPECT_FALSE (boost::filesystem::exists (finished));
}

TEST (OutputSet, ErrorsNameTheFinalPathsNotTheStagingFolders)
{
  EXPECT_EQ (io::OutputSet::finalPaths ("/d/out/.cuefusion-staging-4321-0a9f3c/map.pcd: cannot write"),
             "/d/out/map.pcd: cannot write");
  EXPECT_EQ (io::OutputSet::finalPaths ("out/.cuefusion-staging-7-abcdef: cannot create"), "out: cannot create");
  EXPECT_EQ (io::OutputSet::finalPaths ("/d/.seq.tmp-1b2c3d/gt_cloud.pcd: disk full"), "/d/seq/gt_cloud.pcd: disk full");
  EXPECT_EQ (io::OutputSet::finalPaths ("/d/.quality.tmp-00ff00.png: x"), "/d/quality.png: x");
  // Names that only look alike stay as they are.
  for (const std::string kept : {"/d/.cuefusion-staging-notapid/x: y", "/d/seq.tmp-123456/x: y", "/d/.seq.tmp-XYZ123/x: y",
                                 "no path at all"})
    EXPECT_EQ (io::OutputSet::finalPaths (kept), kept);
  // What a real set stages is named as its final path.
  const test::TempDir dir;
  io::OutputSet set (dir / "out", {"map.pcd"}, "map.pcd");
  EXPECT_EQ (io::OutputSet::finalPaths (set.stagingPath ("map.pcd") + ": e"), set.finalPath ("map.pcd") + ": e");
}

TEST (Sha256, KnownDigestsAndAFile)
{
  // FIPS 180-4's examples (one block, two blocks) and the empty message.
  EXPECT_EQ (io::sha256 (""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ (io::sha256 ("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ (io::sha256 ("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
             "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ (io::sha256 (std::string (1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  test::TempDir dir;
  std::string bytes;
  for (int i = 0; i < 300; ++i)
    bytes.push_back (static_cast<char> (i % 256));  // zero bytes and high bytes too
  test::writeFile (dir / "b.bin", bytes);
  EXPECT_EQ (io::sha256OfFile (dir / "b.bin"), io::sha256 (bytes));
  test::expectError ([&] { io::sha256OfFile (dir / "missing"); }, "missing", "");
}
