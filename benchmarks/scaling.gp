# Draws docs/scaling.{svg,png} from the CSV of benchmarks/scaling (method,triangles,mrays):
# Mrays/s against triangle count, one thread; filled points icospheres, open points random soups
# (soup sizes are powers of two, icosphere sizes are not).
# Usage: gnuplot -e "data='docs/scaling.csv'; out='docs/scaling'" benchmarks/scaling.gp
set datafile separator ','
pow2(x) = (int(x) & (int(x) - 1)) == 0
sel(m, soup) = (strcol(1) eq m && pow2(column(2)) == soup) ? column(2) : NaN
methods = "watertight batch bvh embree"
names = "'scalar loop (watertight)' 'TriangleBatch (MT, SIMD)' 'isin Bvh' 'Embree rtcIntersect1'"
colors = "#7f7f7f #2ca02c #1f77b4 #d62728"
do for [fmt in "svg png"] {
  if (fmt eq "svg") { set terminal svg size 900,560 dynamic font "Helvetica,12" background "white"; set output out.".svg" }
  else { set terminal pngcairo size 900,560 font "Helvetica,11" background "white"; set output out.".png" }
  set title "Mrays/s against triangle count, one thread, 480×270 primary rays (●: icospheres, ○: random soups)"
  set logscale xy
  set xlabel "triangles"
  set ylabel "Mrays/s"
  set format x "10^{%L}"
  set grid
  set key bottom left
  set arrow 1 from 64, graph 0 to 64, graph 1 nohead dt 3 lc rgb "black"
  set label 1 "bvh\\_min = 64" at 70, graph 0.92
  plot for [k=1:4] data using (sel(word(methods, k), 0)):3 with points pt 7 ps 1.4 lc rgb word(colors, k) title word(names, k), \
       for [k=1:4] data using (sel(word(methods, k), 1)):3 with points pt 6 ps 1.4 lc rgb word(colors, k) notitle
  set output
}
