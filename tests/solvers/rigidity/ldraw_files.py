"""LDraw files written the way common editors write them (headers, meta commands, number formats and
line endings as they come out of LDCad, LeoCAD, MLCad and BrickLink Studio)."""

LDCAD = """0 Stacked pair
0 Name: stacked.ldr
0 Author: someone
0 !LDRAW_ORG Unofficial_Model
0 !LICENSE Redistributable under CCAL version 2.0 : see CAreadme.txt
0 BFC CERTIFY CCW
0 !LDCAD GROUP_DEF [topLevel=true] [LID=1] [GID=abc] [name=Group 1] [center=0 0 0]
0 !LDCAD GROUP_NXT [ids=1] [nrs=-1]
1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
0 !LDCAD GROUP_NXT [ids=1] [nrs=-1]
1 14 30 -24 10 1 0 0 0 1 0 0 0 1 3005.dat
0 STEP
"""

LEOCAD = """0 Model exported from LeoCAD
0 Original name: hinge.lcd
0 !LEOCAD MODEL NAME hinge
0 !LEOCAD MODEL AUTHOR someone
1 4 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000 3001.dat
0 !LEOCAD PIECE STEP_HIDE 3
1 15 -20.000000 -24.000000 10.000000 1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000 3937.dat
1 15 -20.000000 -24.000000 10.000000 1.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 1.000000 3938.dat
0 STEP
0 !LEOCAD CAMERA FOV 30 ZNEAR 25 ZFAR 50000 POSITION 0 0 0 TARGET_POSITION 0 0 1 UP_VECTOR 0 1 0 NAME Camera 1
"""

# A technic stack as LDCad saves it, every part where the LDraw library's own frames put it: two 1x4
# technic bricks side by side (their holes along z) pinned through two holes by a 2780 and a 3673,
# each turned a quarter turn about y (the two ways round) because a pin's own axis is x; a 32064 on
# the first brick with an axle 4 centred in its axle hole, turned the same way; on it a hinge brick,
# base 3937 and top 3938 at one position and rotation as editors snap them, and a 1x2 brick on top.
LDCAD_TECHNIC = """0 Technic stack
0 Name: technic.ldr
0 Author: someone
0 !LDRAW_ORG Unofficial_Model
0 BFC CERTIFY CCW
0 !LDCAD GROUP_DEF [topLevel=true] [LID=2] [GID=def] [name=Pinned pair] [center=0 0 10]
0 !LDCAD GROUP_NXT [ids=2] [nrs=-1]
1 71 0 0 0 1 0 0 0 1 0 0 0 1 3701.dat
0 !LDCAD GROUP_NXT [ids=2] [nrs=-1]
1 71 0 0 20 1 0 0 0 1 0 0 0 1 3701.dat
1 0 -20 10 10 0 0 -1 0 1 0 1 0 0 2780.dat
1 1 20 10 10 0 0 1 0 1 0 -1 0 0 3673.dat
0 STEP
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 32064.dat
1 0 0 -14 0 0 0 -1 0 1 0 1 0 0 3705.dat
0 STEP
1 15 0 -48 0 1 0 0 0 1 0 0 0 1 3937.dat
1 15 0 -48 0 1 0 0 0 1 0 0 0 1 3938.dat
1 14 0 -72 0 1 0 0 0 1 0 0 0 1 3004.dat
0 STEP
"""

MLCAD = ("0 Tower\r\n0 Name: tower.ldr\r\n0 Author: MLCad user\r\n0 Unofficial Model\r\n"
         "0 ROTSTEP 0 0 0 ABS\r\n0 MLCAD BTG base\r\n"
         "1 1 0 0 0 1 0 0 0 1 0 0 0 1 3001.DAT\r\n0 MLCAD BTG base\r\n"
         "1 1 0 -24 0 1 0 0 0 1 0 0 0 1 3001.DAT\r\n"
         "0 GHOST 1 7 0 -48 0 1 0 0 0 1 0 0 0 1 3001.DAT\r\n"
         "2 24 0 0 0 10 0 0\r\n3 16 0 0 0 10 0 0 0 10 0\r\n4 16 0 0 0 1 0 0 1 1 0 0 1 0\r\n5 24 0 0 0 1 0 0 0 1 0 1 1 1\r\n"
         "0 STEP\r\n")

STUDIO = ("\ufeff0 FILE main.ldr\n0 Main\n0 Name: main.ldr\n0 Author: \n0 CustomBrick\n0 NumOfBricks: 5\n"
          "1 71 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
          "1 16 -20 -24 0 1 0 0 0 1 0 0 0 1 wing.ldr\n"
          "1 16 20 -24 0 -1 0 0 0 1 0 0 0 -1 wing.ldr\n"
          "1 0 0 -50 0 0.999999 0 0 0 1 0 0 0 1 99999.dat\n"
          "0 NOFILE\n"
          "0 FILE wing.ldr\n0 wing\n0 Name: wing.ldr\n0 Author: \n"
          "1 72 0 0 10 1 0 0 0 1 0 0 0 1 3004.dat\n"
          "0 NOFILE\n")

BROKEN = """0 items that must be skipped one by one
1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat
1 4 0 -24 0 1 0 0 0 1 0 0 0 3001.dat
1 4 0 -24 zero 1 0 0 0 1 0 0 0 1 3001.dat
1 4 0 -24 0 0 0 0 0 0 0 0 0 0 3001.dat
7 this is not ldraw
1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat
"""

SELF_INCLUDING = "0 FILE a.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 a.ldr\n0 NOFILE\n"

ONLY_COMMENTS = "0 nothing here\n0 STEP\n2 24 0 0 0 1 1 1\n"

# As three.js' packer (utils/packLDrawModel.mjs) writes a model with everything it uses: the colour
# configuration first, then the root model's lines with no '0 FILE' of their own, then the root's own
# sub-model, then every file it found in the library as a '0 FILE <folder>/<name>' section, names
# rewritten to the folder they were found in ('parts/s/…' for a subpart, 'p/…' for a primitive). The
# 2 x 2 sits on the 2 x 4's middle four studs, the sub-model puts a 1 x 2 on the 2 x 4's right end.
THREEJS_PACKED = """0 LDraw.org Configuration File
0 Name: LDConfig.ldr
0 Author: James Jessiman
0 !LDRAW_ORG Configuration UPDATE 2017-12-15
0 !COLOUR Black                                                 CODE   0   VALUE #1B2A34   EDGE #2B4354
0 !COLOUR Blue                                                  CODE   1   VALUE #1E5AA8   EDGE #333333
0 !COLOUR Red                                                   CODE   4   VALUE #B40000   EDGE #333333

0 Packed car base
0 Name: car.mpd
0 Author: someone
1 4 0 0 0 1 0 0 0 1 0 0 0 1 parts/3001.dat
1 1 0 -24 0 1 0 0 0 1 0 0 0 1 parts/3003.dat
1 0 30 -24 0 1 0 0 0 1 0 0 0 1 wing.ldr
0 FILE wing.ldr
0 wing
0 Name: wing.ldr
1 14 0 0 0 0 0 -1 0 1 0 1 0 0 parts/3004.dat
0 FILE parts/3001.dat
0 Brick  2 x  4
0 Name: 3001.dat
0 Author: James Jessiman
0 !LDRAW_ORG Part UPDATE 2004-03
0 !LICENSE Redistributable under CCAL version 2.0 : see CAreadme.txt
0 BFC CERTIFY CCW
1 16 0 0 0 1 0 0 0 1 0 0 0 1 parts/s/3001s01.dat
4 16 40 24 20 -40 24 20 -40 24 -20 40 24 -20
0 FILE parts/s/3001s01.dat
0 ~Brick  2 x  4 without Front Face
0 Name: s\\3001s01.dat
0 !LDRAW_ORG Subpart UPDATE 2004-03
1 16 30 0 10 1 0 0 0 1 0 0 0 1 p/stud.dat
1 16 -30 0 10 1 0 0 0 1 0 0 0 1 p/stud.dat
1 16 0 4 0 36 0 0 0 -20 0 0 0 16 p/box5.dat
0 FILE p/stud.dat
0 Stud
0 Name: stud.dat
0 !LDRAW_ORG Primitive UPDATE 2012-01
1 16 0 0 0 6 0 0 0 1 0 0 0 6 p/4-4edge.dat
1 16 0 -4 0 6 0 0 0 1 0 0 0 6 p/4-4edge.dat
0 FILE p/4-4edge.dat
0 Circle 1.0
0 Name: 4-4edge.dat
0 !LDRAW_ORG Primitive UPDATE 2003-02
2 24 1 0 0 0.9239 0 0.3827
0 FILE p/box5.dat
0 Box with 5 Faces
0 Name: box5.dat
0 !LDRAW_ORG Primitive
4 16 1 1 1 -1 1 1 -1 1 -1 1 1 -1
0 FILE parts/3003.dat
0 Brick  2 x  2
0 Name: 3003.dat
0 !LDRAW_ORG Part UPDATE 2002-03
1 16 10 0 10 1 0 0 0 1 0 0 0 1 p/stud.dat
0 FILE parts/3004.dat
0 Brick  1 x  2
0 Name: 3004.dat
0 !LDRAW_ORG Part UPDATE 2002-03
1 16 10 0 0 1 0 0 0 1 0 0 0 1 p/stud.dat

"""

# As Studio and LDCad save a model that uses unofficial parts: the main model is the first '0 FILE',
# the parts' definitions follow as '0 FILE' sections headed 'Unofficial_Part' (with '\' and upper case
# in the names as the part authors wrote them): one is a catalogue number (a 1 x 4 technic brick, so
# it is that brick), one a custom part no catalogue knows (listed as unknown, the rest analysed).
STUDIO_EMBEDDED = ("0 FILE Main.ldr\r\n0 Main\r\n0 Name: Main.ldr\r\n0 Author: \r\n"
                   "1 71 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\r\n"
                   "1 72 0 -24 10 1 0 0 0 1 0 0 0 1 PARTS\\3701.DAT\r\n"
                   "1 0 0 -24 -30 1 0 0 0 1 0 0 0 1 Custom Bracket.dat\r\n"
                   "0 NOFILE\r\n"
                   "0 FILE 3701.dat\r\n0 Technic Brick  1 x  4 with Holes\r\n0 Name: 3701.dat\r\n"
                   "0 Author: someone\r\n0 !LDRAW_ORG Unofficial_Part\r\n0 BFC CERTIFY CCW\r\n"
                   "1 16 0 0 0 1 0 0 0 1 0 0 0 1 S\\3701s01.dat\r\n"
                   "1 16 -20 10 0 1 0 0 0 1 0 0 0 1 peghole.dat\r\n"
                   "0 NOFILE\r\n"
                   "0 FILE s\\3701S01.DAT\r\n0 ~Technic Brick  1 x  4 with Holes without Holes\r\n"
                   "0 Name: s\\3701s01.dat\r\n0 !LDRAW_ORG Unofficial_Subpart\r\n"
                   "1 16 -30 0 0 1 0 0 0 1 0 0 0 1 stud.dat\r\n"
                   "1 16 30 0 0 1 0 0 0 1 0 0 0 1 stud.dat\r\n"
                   "0 NOFILE\r\n"
                   "0 FILE Custom Bracket.dat\r\n0 Custom Bracket\r\n0 Name: Custom Bracket.dat\r\n"
                   "0 Author: someone\r\n0 !LDRAW_ORG Unofficial_Part\r\n"
                   "1 16 0 0 0 1 0 0 0 1 0 0 0 1 stud.dat\r\n"
                   "4 16 10 0 10 -10 0 10 -10 0 -10 10 0 -10\r\n"
                   "0 NOFILE\r\n")

# A technic gearbox as LDCad saves it, in the LDraw library's frames. Two 7-hole beams (32524, along z,
# holes along y) are the walls, 40 LDU apart; two 6-long axles pass through both walls' holes at
# z = -40 and z = 0 (an axle's own x axis turned onto y), carrying a 24-tooth and an 8-tooth gear that
# mesh (centres 40 apart: pitch radii 30 and 10); a 5-hole beam outside wall A is held by two pins and
# the output axle passes through its middle hole; a 1 x 4 technic brick outside wall B, turned so its
# holes run along y, is held by two pins and the output axle passes through it too. A 3-long axle sits
# in wall A's end hole pushed 15 LDU out, 5 LDU off the half-stud grid of its connection points: it
# passes through the hole without a connection being recognised. The file places the pin at z = 60 and the 8-tooth gear twice each, at
# the same pose: those two pairs are the only collisions.
GEARBOX = """0 Gearbox
0 Name: gearbox.ldr
0 Author: someone
0 !LDRAW_ORG Unofficial_Model
0 BFC CERTIFY CCW
1 72 0 0 0 1 0 0 0 1 0 0 0 1 32524.dat
1 72 0 -60 0 1 0 0 0 1 0 0 0 1 32524.dat
0 STEP
1 0 0 -30 -40 0 -1 0 1 0 0 0 0 1 3706.dat
1 14 0 -30 -40 1 0 0 0 0 1 0 -1 0 3648.dat
1 0 0 -30 0 0 -1 0 1 0 0 0 0 1 3706.dat
1 14 0 -30 0 1 0 0 0 0 1 0 -1 0 3647.dat
0 STEP
1 4 0 20 20 1 0 0 0 1 0 0 0 1 32316.dat
1 1 0 10 40 0 -1 0 1 0 0 0 0 1 2780.dat
1 1 0 10 60 0 -1 0 1 0 0 0 0 1 2780.dat
0 STEP
1 71 -10 -80 20 0 1 0 0 0 1 1 0 0 3701.dat
1 0 0 -70 20 0 -1 0 1 0 0 0 0 1 2780.dat
1 0 0 -70 40 0 -1 0 1 0 0 0 0 1 2780.dat
0 STEP
1 7 0 15 -60 0 -1 0 1 0 0 0 0 1 4519.dat
0 STEP
1 1 0 10 60 0 -1 0 1 0 0 0 0 1 2780.dat
1 14 0 -30 0 1 0 0 0 0 1 0 -1 0 3647.dat
0 STEP
"""
