# Draws docs/offsets.{svg,png} from the CSV of benchmarks/offsets: for every case (scene, size,
# distance, eye) and offset method, the median offset of its secondary-ray origins in object
# diagonals (x, log) against its failures — self-hits + lost shadow occlusions — per 1000
# secondary rays (y, log; none observed is drawn on the dashed line). Left float, right double
# (Wächter–Binder is float only).
# Usage: gnuplot -e "data='docs/offsets.csv'; out='docs/offsets'" benchmarks/offsets.gp
set datafile separator ','
floor = 0.01 # per 1000 rays: "none observed" is drawn on this line
methods = "none hit_point fixed error_bound pbrt_v4 wachter_binder"
names = "'none (Ro + t·Rd)' 'hit\\_point, no offset' 'fixed (offset\\_origin, old rule)' 'error\\_bound (isin, new rule)' 'pbrt-v4 (reference)' 'Wächter–Binder (RTG 6)'"
colors = "#7f7f7f #bcbd22 #d62728 #1f77b4 #2ca02c #ff7f0e"
scenes = "trefoil bumpy spheres"
shapes = "7 9 5"     # filled; pbrt-v4 open and larger, so that error_bound shows through where they agree
open_shapes = "6 8 4"
shape(k, j) = (word(methods, k) eq "pbrt_v4") ? int(word(open_shapes, j)) : int(word(shapes, j))
size(k) = (word(methods, k) eq "pbrt_v4") ? 1.7 : 1.1
failures(x) = 1000.0 * (column(13) + column(19)) / (column(10) + column(11) + column(12))
rate(x) = (failures(0) > floor ? failures(0) : floor)
sel(m, s, p) = (strcol(7) eq m && strcol(1) eq s && strcol(6) eq p && column(8) == 1 && column(21) > 0) ? column(21) : NaN

do for [fmt in "svg png"] {
  if (fmt eq "svg") { set terminal svg size 1500,760 dynamic font "Helvetica,11" background "white"; set output out.".svg" }
  else { set terminal pngcairo size 1500,760 font "Helvetica,10" background "white"; set output out.".png" }
  set multiplot layout 1,2 title "Secondary-ray origins: offset size against failures, one point per case and method \n● trefoil knot, ▲ bumpy icosphere, ■ spheres (pbrt-v4 open); on the dashed line: none observed" font ",12"
  set logscale xy
  set format x "10^{%L}"
  set format y "10^{%L}"
  set xrange [1e-16:100]
  set yrange [0.005:1000]
  set grid
  set xlabel "median |origin − exact hit point|, in object diagonals"
  set ylabel "self-hits + lost occlusions per 1000 secondary rays"
  set key below horizontal maxrows 2 font ",10" spacing 1.1 samplen 1.5 width 2
  set bmargin 7.5
  do for [p in "float double"] {
    set title p
    plot for [k=1:words(methods)] for [j=1:words(scenes)] data using (sel(word(methods, k), word(scenes, j), p)):(rate(0)) \
           with points pt shape(k, j) ps size(k) lc rgb word(colors, k) title (j == 1 ? word(names, k) : ""), \
         floor with lines dt 2 lc rgb "gray" notitle
  }
  unset multiplot
  set output
}
