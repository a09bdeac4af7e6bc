camera{location <0,0,-1> look_at 0} light_source{<0,0,-5> color rgb 1}
