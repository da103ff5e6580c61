#!/usr/bin/env bash
# cuefusion as another application sees it (issue 20), on generated data only:
#  1. `cmake --install` into a temporary prefix; the installed command runs with its
#     libraries and data from that prefix (not from the build or source tree);
#  2. examples/ (find_package(cuefusion) and find_package(PCL) only) configure, build and
#     run against the prefix: segment_pcd on an organized PCD, live_segmentation on a
#     sequence through its pcl::Grabber;
#  3. `cpack -G DEB` makes cuefusion_<version>_amd64.deb holding the headers, the command
#     and the CMake config, with Depends naming PCL; the package's files, unpacked into a
#     folder, build the examples too.
# usage: check_install.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
unset CUEFUSION_DATA_DIR
fail () { echo "check_install: $*" >&2; exit 1; }

# 1. install
prefix="$tmp/prefix"
cmake --install "$build" --prefix "$prefix" >"$tmp/install.log" || { cat "$tmp/install.log"; fail "cmake --install failed"; }
bin="$prefix/bin/cuefusion"
for f in include/cuefusion/segmentation/geometric_segmentation.h include/cuefusion/segmentation/edge_comparators.h \
         lib/cmake/cuefusion/cuefusionConfig.cmake lib/cmake/cuefusion/cuefusionConfigVersion.cmake \
         share/cuefusion/scenes/tabletop.scene share/cuefusion/models/xyz_instances.onnx; do
  [ -f "$prefix/$f" ] || fail "not installed: $f"
done
[ -x "$bin" ] || fail "not installed: bin/cuefusion"
# Shared libraries with a versioned SONAME, found by the command beside it.
lib=$(ls "$prefix"/lib/libcuefusion_segmentation.so.* | head -1)
objdump -p "$lib" | grep -q 'SONAME.*libcuefusion_segmentation\.so\.[0-9]' || fail "$lib has no versioned SONAME"
ldd "$bin" | grep libcuefusion_ | grep -v "$prefix/" && fail "installed cuefusion loads libraries from outside $prefix"
# A scene that only the installed data folder has: found relative to the installed library.
sed 's/^scene .*/scene installed_only/' "$prefix/share/cuefusion/scenes/tabletop.scene" \
  >"$prefix/share/cuefusion/scenes/installed_only.scene"
"$bin" synth --scene installed_only --frames 12 --size 320x240 --out "$tmp/sequence" >"$tmp/synth.log" 2>&1 \
  || { cat "$tmp/synth.log"; fail "installed cuefusion did not find its installed scenes"; }
# PCL's visualization (VTK's rendering, Qt) and video I/O are not linked into the command;
# `run --video` loads them from the installed display library.
ldd "$bin" | grep -E 'libpcl_visualization|libvtkRenderingOpenGL|libQt|libopencv_videoio' && fail "installed cuefusion links the viewer's or video's libraries"
# Nor the pipeline: info, synth and synth-views run without it; the other commands load
# libcuefusion_commands.so (segment-frame and run below come from the installed one).
ldd "$bin" | grep -E 'libcuefusion_pipeline|libpcl_segmentation|libopencv_dnn' && fail "installed cuefusion links the pipeline"
"$bin" run "$tmp/sequence" --frames 3 --out "$tmp/run" --video "$tmp/run.avi" >"$tmp/run.log" 2>&1 \
  || { cat "$tmp/run.log"; fail "installed cuefusion could not write a video"; }
[ -s "$tmp/run.avi" ] || fail "installed cuefusion run --video wrote no video"

# 2. the examples, built against the prefix only
cmake -S "$source/examples" -B "$tmp/examples" -DCMAKE_PREFIX_PATH="$prefix" >"$tmp/examples.log" 2>&1 \
  || { cat "$tmp/examples.log"; fail "examples: configure failed"; }
cmake --build "$tmp/examples" -j "${CUEFUSION_JOBS:-2}" >>"$tmp/examples.log" 2>&1 \
  || { cat "$tmp/examples.log"; fail "examples: build failed"; }
depth=$(ls "$tmp"/sequence/depth/*.png | head -1)
rgb=$(ls "$tmp"/sequence/rgb/*.png | head -1)
"$bin" segment-frame "$depth" --intrinsics "$tmp/sequence/intrinsics.txt" --depth-scale 5000 --rgb "$rgb" \
  --out "$tmp/frame.pcd" >/dev/null
# The shipped network by name, from a folder outside the source tree (issue 40).
(cd "$tmp" && "$bin" segment-frame "$depth" --intrinsics "$tmp/sequence/intrinsics.txt" --depth-scale 5000 \
  --model xyz_instances --mode masks --out "$tmp/masks.pcd" >"$tmp/masks.log" 2>&1) \
  || { cat "$tmp/masks.log"; fail "installed cuefusion did not find --model xyz_instances"; }
[ -f "$tmp/masks.pcd" ] || fail "segment-frame --model xyz_instances wrote no masks.pcd"
mkdir "$tmp/segments"
"$tmp/examples/segment_pcd" "$tmp/frame.pcd" "$tmp/segments" 3 100
[ -f "$tmp/segments/labelled.pcd" ] || fail "segment_pcd wrote no labelled.pcd"
n=$(ls "$tmp"/segments/segment_*.pcd 2>/dev/null | wc -l)
[ "$n" -ge 3 ] || fail "segment_pcd wrote $n segments, expected the table and objects (>= 3)"
mkdir "$tmp/live"
"$tmp/examples/live_segmentation" "$tmp/sequence" "$tmp/live" 5 | tee "$tmp/live.log"
grep -q '^12 frames, 12 tracked$' "$tmp/live.log" || fail "live_segmentation did not track all 12 frames"
for f in map_00005.pcd map_00010.pcd map_final.pcd; do
  [ -f "$tmp/live/$f" ] || fail "live_segmentation wrote no $f"
done

# 3. the Debian package
(cd "$build" && cpack -G DEB -B "$tmp/package" >"$tmp/cpack.log" 2>&1) || { cat "$tmp/cpack.log"; fail "cpack -G DEB failed"; }
deb=$(ls "$tmp"/package/cuefusion_*_amd64.deb 2>/dev/null | head -1)
[ -n "$deb" ] || fail "cpack made no cuefusion_<version>_amd64.deb"
dpkg-deb -c "$deb" >"$tmp/contents"
for f in libcuefusion_run_display.so libcuefusion_commands.so; do
  grep -q "/$f\$" "$tmp/contents" || fail "$(basename "$deb") lacks $f"
done
for f in ./usr/bin/cuefusion ./usr/include/cuefusion/segmentation/geometric_segmentation.h \
         ./usr/lib/cmake/cuefusion/cuefusionConfig.cmake ./usr/share/cuefusion/models/xyz_instances.onnx \
         ./usr/share/doc/cuefusion/copyright; do
  grep -q " $f\$" "$tmp/contents" || fail "$(basename "$deb") lacks $f"
done
depends=$(dpkg-deb -f "$deb" Depends)
echo "$(basename "$deb") Depends: $depends"
echo "$depends" | grep -q 'libpcl-dev' || fail "Depends does not name PCL's development package"
echo "$depends" | grep -q 'libpcl-.*1\.13' || fail "Depends does not name PCL's run-time libraries"
dpkg-deb -x "$deb" "$tmp/root"
cmake -S "$source/examples" -B "$tmp/examples-deb" -DCMAKE_PREFIX_PATH="$tmp/root/usr" >"$tmp/examples-deb.log" 2>&1 \
  || { cat "$tmp/examples-deb.log"; fail "examples against the unpacked package: configure failed"; }
echo "check_install: install, examples and package all right"
