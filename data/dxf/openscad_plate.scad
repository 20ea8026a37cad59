// A 60 x 40 mm plate with rounded corners, a 12 mm hole and a slot (OpenSCAD 2-D export test)
$fn = 48;
difference() {
  offset(r = 4) square([52, 32], center = true);
  translate([-15, 0]) circle(d = 12);
  hull() { translate([10, -6]) circle(d = 5); translate([18, 6]) circle(d = 5); }
}
