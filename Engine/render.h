// crowdhealth render — draws PNG frames and an animation of a scenario or of a finished run,
// without a display (gnuplot's pngcairo and gif terminals; MP4 through ffmpeg when installed).
//
//   crowdhealth render -i SCENARIO -o OUTDIR --time T [--every S] [--size WxH] [--color C]
//   crowdhealth render --replay RUNDIR -o OUTDIR [--time T] [--every S] ...
//
// Writes into OUTDIR: frame_0000.png …, animation.gif (and animation.mp4) when there is more
// than one frame, render-data.txt (the numbers drawn), render.gp (the gnuplot script, to restyle
// by hand) and render.json (frames, times and the world-to-pixel mapping). See docs/rendering.md.
#pragma once

namespace chcli {

/// Runs the `render` subcommand; argv[0] is "render". Returns an exit status (exit_codes.h):
/// 0, 1 (gnuplot missing or failed, files not writable), 2 (bad command line or scenario).
int renderCommand(int argc, char* argv[]);

}  // namespace chcli
