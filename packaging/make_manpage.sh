#!/usr/bin/env bash
# The cuefusion(1) man page, generated from the command's own help (help2man): the
# synopsis and command list from `cuefusion --help`, then each command's options from
# `cuefusion COMMAND --help`, so the page never drifts from the program.
# usage: make_manpage.sh CUEFUSION_BINARY OUT.1.gz
set -euo pipefail
binary="$1"
out="$2"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
{
  echo "[COMMANDS AND THEIR OPTIONS]"
  for command in synth synth-views info run segment-frame eval render batch; do
    echo ".SS $command"
    echo ".nf"
    # roff: a leading dot or quote starts a request, backslashes escape
    "$binary" "$command" --help | sed -e 's/\\/\\e/g' -e "s/^\([.']\)/\\\\\&\1/"
    echo ".fi"
  done
  echo "[FILES]"
  echo "Settings files (--config): JSON of the library's Config fields; see --print-config."
  echo "Data (scenes, class lists, the xyz_instances network): /usr/share/cuefusion."
  echo "[SEE ALSO]"
  echo "The documentation in /usr/share/doc/cuefusion and the project's docs/ folder."
} >"$tmp/include"
help2man --no-info --no-discard-stderr --section 1 \
  --name "incremental object-level 3D segmentation of RGB-D sequences" \
  --include "$tmp/include" --output "$tmp/cuefusion.1" "$binary"
gzip -9n <"$tmp/cuefusion.1" >"$out"
