# Draws docs/accuracy_vs_speed.{svg,png} from the points CSV of benchmarks/accuracy_vs_speed:
# one panel per workload group, x = ns per test (one core), y = error rate, log scales.
# Usage: gnuplot -e "points='docs/accuracy_vs_speed_points.csv'; out='docs/accuracy_vs_speed'" benchmarks/accuracy_vs_speed.gp
set datafile separator ','
floor = 3e-6  # "no error observed" is drawn on this line
tri = "area-note area-relative moller-trumbore moller-trumbore-cull moller-trumbore-batch watertight baldwin-weber"
sph = "sphere-note sphere-note-fix sphere-quadratic sphere-rtg sphere-isin"
groups = "random edges grazing scale sliver restart"
titles = "'random triangles (wrong hit/miss)' 'rays at shared edges (leak rate)' 'grazing, 1e-1…1e-7 rad (wrong hit/miss)' 'size 1e-4…1e6, 1e7 away (wrong hit/miss)' 'slivers, aspect 10…1e6 (wrong hit/miss)' 'spheres: restart on surface (self-hits + missed exits)'"
rate(x) = (x > floor ? x : floor)
colors = "#d62728 #ff7f0e #1f77b4 #17becf #2ca02c #9467bd #8c564b"
sel(g, m, p) = (strcol(1) eq g && strcol(2) eq m && strcol(3) eq p) ? column(4) : NaN

do for [fmt in "svg png"] {
  if (fmt eq "svg") { set terminal svg size 1500,950 dynamic font "Helvetica,11" background "white"; set output out.".svg" }
  else { set terminal pngcairo size 1500,950 font "Helvetica,10" background "white"; set output out.".png" }
  set multiplot layout 2,3 title "isin: accuracy against speed, one core (x: ns per test; y: error rate; ● float, ▲ double; on the dashed line: none observed)" font ",13"
  set logscale xy
  set xrange [0.5:60]
  set yrange [1e-6:1.5]
  set format y "10^{%L}"
  set grid
  set key top right font ",8" spacing 0.9 samplen 1
  do for [i=1:6] {
    g = word(groups, i)
    set title word(titles, i)
    set xlabel "ns per test"
    set ylabel "error rate"
    if (g eq "restart") { ms = sph } else { ms = tri }
    plot for [k=1:words(ms)] points using (sel(g, word(ms, k), "float")):(rate(column(7))) with points pt 7 ps 1.3 lc rgb word(colors, k) title word(ms, k), \
         for [k=1:words(ms)] points using (sel(g, word(ms, k), "double")):(rate(column(7))) with points pt 9 ps 1.5 lc rgb word(colors, k) notitle, \
         floor with lines dt 2 lc rgb "gray" notitle
  }
  unset multiplot
  set output
}
